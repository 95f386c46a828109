#include "pg/spherical/room_planes.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include "pg/camera/camera.h"

namespace pg {

namespace {

constexpr double degrees = 180 / std::numbers::pi;

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * degrees;
}

double median_range(const std::vector<Eigen::Vector3d>& points) {
  std::vector<double> ranges;
  for (const Eigen::Vector3d& p : points) ranges.push_back(p.norm());
  if (ranges.empty()) return 0;
  std::nth_element(ranges.begin(), ranges.begin() + ranges.size() / 2, ranges.end());
  return ranges[ranges.size() / 2];
}

// RANSAC over `points` for the plane with most inliers within `threshold`; refined by least squares
// on its inliers. Returns the fit and marks its inliers.
// `accept` filters the hypotheses by their unit normal.
std::optional<PlaneFit> ransac_plane(const std::vector<Eigen::Vector3d>& points, double threshold,
                                     int iterations, std::mt19937_64& random, std::vector<bool>& inlier,
                                     const std::function<bool(const Eigen::Vector3d&)>& accept) {
  inlier.assign(points.size(), false);
  if (points.size() < 3) return std::nullopt;
  std::uniform_int_distribution<std::size_t> pick(0, points.size() - 1);
  Eigen::Vector3d best_normal = Eigen::Vector3d::Zero();
  double best_offset = 0;
  std::size_t best_count = 0;
  for (int i = 0; i < iterations; ++i) {
    const Eigen::Vector3d& a = points[pick(random)];
    const Eigen::Vector3d normal = (points[pick(random)] - a).cross(points[pick(random)] - a);
    if (normal.norm() < 1e-12) continue;
    const Eigen::Vector3d n = normal.normalized();
    if (!accept(n)) continue;
    const double offset = -n.dot(a);
    std::size_t count = 0;
    for (const Eigen::Vector3d& p : points) count += std::abs(n.dot(p) + offset) < threshold;
    if (count > best_count) best_count = count, best_normal = n, best_offset = offset;
  }
  if (best_count < 3) return std::nullopt;
  std::vector<Eigen::Vector3d> members;
  for (std::size_t i = 0; i < points.size(); ++i) {
    inlier[i] = std::abs(best_normal.dot(points[i]) + best_offset) < threshold;
    if (inlier[i]) members.push_back(points[i]);
  }
  return fit_plane(members);
}

}  // namespace

PlaneFit fit_plane(const std::vector<Eigen::Vector3d>& points) {
  PlaneFit fit;
  fit.inliers = points.size();
  if (points.size() < 3) return fit;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  fit.normal = solver.eigenvectors().col(0).normalized();
  fit.offset = -fit.normal.dot(mean);
  if (fit.offset < 0) fit.normal = -fit.normal, fit.offset = -fit.offset;  // towards the origin
  double sum = 0;
  for (const Eigen::Vector3d& p : points) sum += std::pow(fit.normal.dot(p) + fit.offset, 2);
  fit.rms = std::sqrt(sum / static_cast<double>(points.size()));
  return fit;
}

RoomPlanes fit_room_planes(const DepthMap& map, const RoomPlaneOptions& options) {
  const cv::Mat1f depth = map.depth;
  const double floor_cos = std::cos(options.floor_cone_deg / degrees);
  const double wall_sin = std::sin(options.wall_band_deg / degrees);
  std::vector<Eigen::Vector3d> floor_points, wall_points;
  // Every second pixel is plenty for a plane and halves the RANSAC cost.
  for (int y = 0; y < depth.rows; y += 2) {
    for (int x = 0; x < depth.cols; x += 2) {
      const float range = depth(y, x);
      if (!std::isfinite(range) || range <= 0) continue;
      const Eigen::Vector3d ray =
          map.camera.model == CameraModel::equirectangular
              ? equirect_direction_from_pixel(depth.cols, depth.rows, Eigen::Vector2d(x, y))
              : map.camera.unproject(Eigen::Vector2d(x, y));
      if (ray.y() > floor_cos) floor_points.push_back(range * ray);
      if (std::abs(ray.y()) < wall_sin) wall_points.push_back(range * ray);
    }
  }
  RoomPlanes planes;
  std::mt19937_64 random(options.seed);
  std::vector<bool> inlier;
  planes.floor =
      ransac_plane(floor_points, options.inlier_fraction * median_range(floor_points), options.iterations,
                   random, inlier, [](const Eigen::Vector3d&) { return true; });
  // Walls are the planes closer to vertical than to horizontal (the angles reported are measured).
  const Eigen::Vector3d up = planes.floor ? planes.floor->normal : Eigen::Vector3d(0, -1, 0);
  const auto is_wall = [&](const Eigen::Vector3d& n) { return std::abs(n.dot(up)) < std::sqrt(0.5); };
  // Walls one after another, each from the points the previous ones did not take.
  const double wall_threshold = options.inlier_fraction * median_range(wall_points);
  const std::size_t min_inliers = static_cast<std::size_t>(options.min_wall_share * wall_points.size());
  std::vector<Eigen::Vector3d> remaining = wall_points;
  if (planes.floor) {  // the floor's own points near the horizon are not wall candidates
    std::erase_if(remaining, [&](const Eigen::Vector3d& p) {
      return std::abs(planes.floor->normal.dot(p) + planes.floor->offset) < wall_threshold;
    });
  }
  for (int w = 0; w < options.max_walls; ++w) {
    const std::optional<PlaneFit> wall =
        ransac_plane(remaining, wall_threshold, options.iterations, random, inlier, is_wall);
    if (!wall || wall->inliers < std::max<std::size_t>(min_inliers, 3)) break;
    planes.walls.push_back(*wall);
    std::vector<Eigen::Vector3d> rest;
    for (std::size_t i = 0; i < remaining.size(); ++i)
      if (!inlier[i]) rest.push_back(remaining[i]);
    remaining = std::move(rest);
  }
  for (std::size_t i = 0; i < planes.walls.size(); ++i) {
    if (planes.floor)
      planes.wall_floor_angles_deg.push_back(angle_deg(planes.walls[i].normal, planes.floor->normal));
    for (std::size_t j = i + 1; j < planes.walls.size(); ++j) {
      const double angle = angle_deg(planes.walls[i].normal, planes.walls[j].normal);
      planes.wall_wall_angles_deg.push_back(std::min(angle, 180 - angle));
    }
  }
  return planes;
}

nlohmann::json RoomPlanes::to_json() const {
  const auto plane_json = [](const PlaneFit& p) {
    return nlohmann::json{{"normal", {p.normal.x(), p.normal.y(), p.normal.z()}},
                          {"distance", p.offset},
                          {"inliers", p.inliers},
                          {"rms", p.rms}};
  };
  nlohmann::json out;
  out["floor"] = floor ? plane_json(*floor) : nlohmann::json();
  out["walls"] = nlohmann::json::array();
  for (const PlaneFit& wall : walls) out["walls"].push_back(plane_json(wall));
  out["wall_floor_angles_deg"] = wall_floor_angles_deg;
  out["wall_wall_angles_deg"] = wall_wall_angles_deg;
  return out;
}

}  // namespace pg
