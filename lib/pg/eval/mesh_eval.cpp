#include "pg/eval/mesh_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"
#include "pg/mesh/bvh.h"

namespace pg {
namespace {

constexpr std::int64_t sample_chunk = 8192;  // fixed chunking keeps samples independent of threads
constexpr std::int64_t query_chunk = 1024;

// SplitMix64: tiny, well mixed, and identical on every platform (unlike std:: distributions).
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

double face_area(const Mesh& mesh, const std::array<std::uint32_t, 3>& f) {
  Eigen::Vector3d a = mesh.positions[f[0]].cast<double>();
  Eigen::Vector3d b = mesh.positions[f[1]].cast<double>();
  Eigen::Vector3d c = mesh.positions[f[2]].cast<double>();
  return 0.5 * (b - a).cross(c - a).norm();
}

double total_area(const Mesh& mesh) {
  double total = 0;
  for (const auto& f : mesh.faces) total += face_area(mesh, f);
  return total;
}

// Samples plus the vertices that some face uses (stray vertices are not surface).
std::vector<Eigen::Vector3f> measurement_points(const Mesh& mesh, const MeshEvalOptions& options,
                                                std::uint64_t seed) {
  std::vector<Eigen::Vector3f> points = sample_surface(mesh, options.samples, seed);
  if (options.include_vertices) {
    std::vector<bool> used(mesh.positions.size(), false);
    for (const auto& f : mesh.faces)
      for (std::uint32_t v : f) used[v] = true;
    for (std::size_t v = 0; v < used.size(); ++v)
      if (used[v]) points.push_back(mesh.positions[v]);
  }
  return points;
}

// Distance from each point to the surface, in the points' order.
std::vector<double> distances_to(const TriangleBvh& surface, const std::vector<Eigen::Vector3f>& points) {
  std::vector<double> distances(points.size());
  parallel_chunks(std::int64_t(points.size()), query_chunk, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t i = begin; i < end; ++i)
      distances[i] = surface.closest_point(points[i], std::numeric_limits<float>::infinity()).distance;
  });
  return distances;
}

std::vector<double> fractions_within(const std::vector<double>& sorted,
                                     const std::vector<double>& thresholds) {
  std::vector<double> fractions;
  for (double t : thresholds) fractions.push_back(sorted_fraction_at_most(sorted, t));
  return fractions;
}

}  // namespace

std::vector<Eigen::Vector3f> sample_surface(const Mesh& mesh, std::size_t count, std::uint64_t seed) {
  std::vector<double> cumulative(mesh.faces.size());
  double total = 0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) cumulative[f] = total += face_area(mesh, mesh.faces[f]);
  if (!(total > 0) || count == 0) return {};

  std::vector<Eigen::Vector3f> samples(count);
  parallel_chunks(std::int64_t(count), sample_chunk, [&](std::int64_t begin, std::int64_t end) {
    SplitMix64 rng{seed ^ (0x632be59bd9b4e019ull * std::uint64_t(begin / sample_chunk + 1))};
    for (std::int64_t i = begin; i < end; ++i) {
      // upper_bound skips zero-area faces: their cumulative value equals their predecessor's.
      auto it = std::upper_bound(cumulative.begin(), cumulative.end(), rng.uniform() * total);
      const auto& f = mesh.faces[std::min<std::size_t>(it - cumulative.begin(), mesh.faces.size() - 1)];
      double root = std::sqrt(rng.uniform()), r2 = rng.uniform();
      double wa = 1 - root, wb = root * (1 - r2), wc = root * r2;
      Eigen::Vector3d p = wa * mesh.positions[f[0]].cast<double>() +
                          wb * mesh.positions[f[1]].cast<double>() + wc * mesh.positions[f[2]].cast<double>();
      samples[i] = p.cast<float>();
    }
  });
  return samples;
}

MeshEvalResult evaluate_mesh(const Mesh& estimate, const Mesh& truth, const MeshEvalOptions& options) {
  estimate.check_consistent();
  truth.check_consistent();
  if (!(total_area(estimate) > 0)) throw FailedError("the estimate mesh has no surface (no faces with area)");
  if (!(total_area(truth) > 0)) throw FailedError("the truth mesh has no surface (no faces with area)");

  MeshEvalResult r;
  r.thresholds = options.thresholds;
  // Different seeds for the two sides, so that identical meshes are not sampled at identical points.
  std::vector<Eigen::Vector3f> estimate_points = measurement_points(estimate, options, options.seed);
  std::vector<Eigen::Vector3f> truth_points = measurement_points(truth, options, ~options.seed);
  r.estimate_points = estimate_points.size();
  r.truth_points = truth_points.size();

  std::vector<double> accuracy = distances_to(TriangleBvh(truth), estimate_points);
  std::vector<double> completeness = distances_to(TriangleBvh(estimate), truth_points);
  r.accuracy = summarize(accuracy);  // sorts
  r.completeness = summarize(completeness);
  r.chamfer = 0.5 * (r.accuracy.mean + r.completeness.mean);
  r.precision = fractions_within(accuracy, options.thresholds);
  r.recall = fractions_within(completeness, options.thresholds);
  for (std::size_t i = 0; i < options.thresholds.size(); ++i) {
    double p = r.precision[i], q = r.recall[i];
    r.fscore.push_back(p + q > 0 ? 2 * p * q / (p + q) : 0.0);
  }
  return r;
}

nlohmann::json MeshEvalResult::to_json() const {
  nlohmann::json at = nlohmann::json::array();
  for (std::size_t i = 0; i < thresholds.size(); ++i)
    at.push_back({{"threshold", thresholds[i]},
                  {"precision", precision[i]},
                  {"recall", recall[i]},
                  {"fscore", fscore[i]}});
  return {{"estimate_points", estimate_points}, {"truth_points", truth_points},
          {"accuracy", accuracy.to_json()},     {"completeness", completeness.to_json()},
          {"chamfer", json_number(chamfer)},    {"thresholds", std::move(at)}};
}

std::string MeshEvalResult::to_text() const {
  std::string text = str(
      "Accuracy (estimate to truth, ", estimate_points, " points): mean ", accuracy.mean, ", median ",
      accuracy.median, ", p90 ", accuracy.p90, ", p95 ", accuracy.p95, ", p99 ", accuracy.p99, ", max ",
      accuracy.max, ". Completeness (truth to estimate, ", truth_points, " points): mean ", completeness.mean,
      ", median ", completeness.median, ", p90 ", completeness.p90, ", p95 ", completeness.p95, ", p99 ",
      completeness.p99, ", max ", completeness.max, ". Chamfer ", chamfer, " (scene units).");
  for (std::size_t i = 0; i < thresholds.size(); ++i)
    text += str(" Within ", thresholds[i], ": precision ", precision[i], ", recall ", recall[i], ", F-score ",
                fscore[i], ".");
  return text;
}

}  // namespace pg
