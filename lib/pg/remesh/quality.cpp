#include "pg/remesh/quality.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

#include "pg/core/parallel.h"
#include "pg/mesh/bvh.h"
#include "pg/remesh/remesh.h"
#include "pg/remesh/sizing.h"

namespace pg {
namespace {

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

double ratio(std::size_t part, std::size_t whole) {
  return whole ? double(part) / double(whole) : 0.0;
}

nlohmann::ordered_json histogram_json(const Histogram& h) {
  return {{"lo", h.lo}, {"hi", h.hi}, {"counts", h.counts}};
}

// Sample points of the selected faces: vertices and a barycentric lattice; appended to `points`.
void sample_faces(const Mesh& mesh, const std::vector<bool>& faces, float spacing,
                  std::vector<Eigen::Vector3f>& points) {
  std::vector<bool> vertex_used(mesh.vertex_count(), false);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    if (!faces.empty() && !faces[f]) continue;
    const auto& v = mesh.faces[f];
    const Eigen::Vector3f &a = mesh.positions[v[0]], &b = mesh.positions[v[1]], &c = mesh.positions[v[2]];
    for (std::uint32_t i : v)
      if (!vertex_used[i]) {
        vertex_used[i] = true;
        points.push_back(mesh.positions[i]);
      }
    const float longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int k = std::clamp(int(std::ceil(longest / spacing)), 1, 64);
    for (int i = 0; i <= k; ++i)
      for (int j = 0; i + j <= k; ++j) {
        if ((i == 0 && j == 0) || (i == k) || (j == k)) continue;  // the corners are vertices
        const float u = float(i) / float(k), w = float(j) / float(k);
        points.push_back(a + u * (b - a) + w * (c - a));
      }
  }
}

double max_distance(const std::vector<Eigen::Vector3f>& points, const TriangleBvh& surface) {
  const auto n = std::int64_t(points.size());
  std::mutex mutex;
  double result = 0;
  parallel_chunks(n, 4096, [&](std::int64_t begin, std::int64_t end) {
    double local = 0;
    for (std::int64_t i = begin; i < end; ++i)
      local = std::max(local, double(surface.closest_point(points[i]).distance));
    std::lock_guard lock(mutex);
    result = std::max(result, local);  // max does not depend on the order
  });
  return result;
}

}  // namespace

void Histogram::add(double value) {
  const double width = (hi - lo) / double(counts.size());
  const double bin = std::floor((value - lo) / width);
  counts[std::size_t(std::clamp(bin, 0.0, double(counts.size() - 1)))]++;
}

std::size_t Histogram::total() const {
  std::size_t sum = 0;
  for (std::size_t c : counts) sum += c;
  return sum;
}

std::vector<bool> faces_within(const Mesh& mesh, const std::vector<bool>& selected) {
  std::vector<bool> faces(mesh.face_count(), true);
  if (selected.empty()) return faces;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& v = mesh.faces[f];
    faces[f] = selected[v[0]] && selected[v[1]] && selected[v[2]];
  }
  return faces;
}

MeshQuality measure_quality(const Mesh& mesh, const std::vector<bool>& selected,
                            const std::vector<float>& target) {
  const auto is_selected = [&](std::uint32_t v) { return selected.empty() || selected[v]; };
  MeshQuality q;
  std::size_t good_angles = 0;
  q.smallest_angle_deg = 180;
  // Undirected edges with how many faces use them (1 = boundary).
  std::vector<std::uint64_t> edges;
  edges.reserve(mesh.faces.size() * 3);
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = f[k], b = f[(k + 1) % 3];
      edges.push_back((std::uint64_t(std::min(a, b)) << 32) | std::max(a, b));
    }
    if (!(is_selected(f[0]) && is_selected(f[1]) && is_selected(f[2]))) continue;
    double smallest = 180;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = mesh.positions[f[k]].cast<double>();
      smallest = std::min(smallest, angle_deg(mesh.positions[f[(k + 1) % 3]].cast<double>() - p,
                                              mesh.positions[f[(k + 2) % 3]].cast<double>() - p));
    }
    q.min_angle_deg.add(smallest);
    q.smallest_angle_deg = std::min(q.smallest_angle_deg, smallest);
    good_angles += smallest > 30;
    ++q.faces;
  }
  std::sort(edges.begin(), edges.end());
  std::vector<int> valence(mesh.vertex_count(), 0);
  std::vector<bool> boundary(mesh.vertex_count(), false);
  std::size_t in_range = 0;
  double ratio_sum = 0;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    const auto a = std::uint32_t(edges[i] >> 32), b = std::uint32_t(edges[i] & 0xffffffffu);
    ++valence[a], ++valence[b];
    if (j - i == 1) boundary[a] = boundary[b] = true;
    if (is_selected(a) && is_selected(b)) {
      const double r = (mesh.positions[a] - mesh.positions[b]).cast<double>().norm() /
                       (0.5 * (double(target[a]) + target[b]));
      q.edge_ratio.add(r);
      ratio_sum += r;
      in_range += r >= 0.8 && r <= 1.33;
      ++q.edges;
    }
    i = j;
  }
  std::size_t six = 0;
  for (std::size_t v = 0; v < valence.size(); ++v)
    if (is_selected(std::uint32_t(v)) && !boundary[v] && valence[v] > 0) {
      q.valence.add(valence[v]);
      six += valence[v] == 6;
      ++q.vertices;
    }
  q.edges_in_range = ratio(in_range, q.edges);
  q.angles_above_30 = ratio(good_angles, q.faces);
  q.valence_6 = ratio(six, q.vertices);
  q.mean_edge_ratio = q.edges ? ratio_sum / double(q.edges) : 0.0;
  if (q.faces == 0) q.smallest_angle_deg = 0;
  return q;
}

nlohmann::ordered_json MeshQuality::to_json() const {
  return {{"faces", faces},
          {"edges", edges},
          {"interior_vertices", vertices},
          {"edges_within_0.8_1.33", edges_in_range},
          {"mean_edge_ratio", mean_edge_ratio},
          {"min_angle_above_30", angles_above_30},
          {"smallest_angle_deg", smallest_angle_deg},
          {"valence_6", valence_6},
          {"edge_ratio_histogram", histogram_json(edge_ratio)},
          {"min_angle_histogram", histogram_json(min_angle_deg)},
          {"valence_histogram", histogram_json(valence)}};
}

namespace {

// hausdorff_distance with the two surfaces' hierarchies given (a_bvh over a, b_bvh over b).
HausdorffDistance hausdorff_with(const Mesh& a, const std::vector<bool>& a_faces, const TriangleBvh& a_bvh,
                                 const Mesh& b, const std::vector<bool>& b_faces, const TriangleBvh& b_bvh,
                                 float spacing) {
  std::vector<Eigen::Vector3f> a_points, b_points;
  sample_faces(a, a_faces, spacing, a_points);
  sample_faces(b, b_faces, spacing, b_points);
  HausdorffDistance h;
  h.a_to_b = a_points.empty() ? 0.0 : max_distance(a_points, b_bvh);
  h.b_to_a = b_points.empty() ? 0.0 : max_distance(b_points, a_bvh);
  h.distance = std::max(h.a_to_b, h.b_to_a);
  h.samples = a_points.size() + b_points.size();
  return h;
}

}  // namespace

HausdorffDistance hausdorff_distance(const Mesh& a, const std::vector<bool>& a_faces, const Mesh& b,
                                     const std::vector<bool>& b_faces, float spacing) {
  return hausdorff_with(a, a_faces, TriangleBvh(a), b, b_faces, TriangleBvh(b), spacing);
}

std::vector<bool> smooth_vertices(const Mesh& mesh, float length, float radius_factor) {
  // The largest curvature within about `length` of each vertex: a triangle of side L there spans it.
  std::vector<float> curvature = max_abs_curvature(mesh, 0);
  const float edge = mean_edge_length(mesh);
  const int rings = edge > 0 ? std::max(1, int(std::ceil(length / edge))) : 1;
  for (int ring = 0; ring < rings; ++ring) {
    std::vector<float> grown = curvature;
    for (const auto& f : mesh.faces)
      for (int k = 0; k < 3; ++k)
        grown[f[k]] = std::max({grown[f[k]], curvature[f[(k + 1) % 3]], curvature[f[(k + 2) % 3]]});
    curvature = std::move(grown);
  }
  const std::vector<bool> boundary = boundary_vertices(mesh);
  std::vector<bool> smooth(curvature.size());
  for (std::size_t v = 0; v < curvature.size(); ++v)
    smooth[v] = !boundary[v] && double(curvature[v]) * radius_factor * length <= 1.0;
  return smooth;
}

SmoothRegionHausdorff smooth_region_hausdorff(const Mesh& output, const Mesh& input,
                                              const std::vector<bool>& input_faces, float length,
                                              float radius_factor, float spacing) {
  SmoothRegionHausdorff result;
  result.radius_factor = radius_factor;
  std::vector<bool> smooth_faces = faces_within(input, smooth_vertices(input, length, radius_factor));
  std::size_t selected = 0, smooth = 0;
  for (std::size_t f = 0; f < smooth_faces.size(); ++f) {
    const bool is_selected = input_faces.empty() || input_faces[f];
    smooth_faces[f] = smooth_faces[f] && is_selected;
    selected += is_selected;
    smooth += smooth_faces[f];
  }
  if (smooth == 0) return result;
  result.input_fraction = double(smooth) / double(selected);
  const TriangleBvh input_bvh(input);
  std::vector<std::uint8_t> closest_is_smooth(output.vertex_count());  // bytes: written in parallel
  parallel_chunks(std::int64_t(output.vertex_count()), 4096, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t v = begin; v < end; ++v) {
      const std::uint32_t face = input_bvh.closest_point(output.positions[v]).face;
      closest_is_smooth[v] = face < smooth_faces.size() && smooth_faces[face];
    }
  });
  const std::vector<bool> output_faces =
      faces_within(output, std::vector<bool>(closest_is_smooth.begin(), closest_is_smooth.end()));
  // An empty selection would mean every face.
  if (std::find(output_faces.begin(), output_faces.end(), true) == output_faces.end()) return result;
  result.hausdorff =
      hausdorff_with(output, output_faces, TriangleBvh(output), input, smooth_faces, input_bvh, spacing);
  return result;
}

}  // namespace pg
