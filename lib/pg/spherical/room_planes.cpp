#include "pg/spherical/room_planes.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
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
// on its inliers.
std::optional<PlaneFit> ransac_plane(const std::vector<Eigen::Vector3d>& points, double threshold,
                                     int iterations, std::mt19937_64& random) {
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
    const double offset = -n.dot(a);
    std::size_t count = 0;
    for (const Eigen::Vector3d& p : points) count += std::abs(n.dot(p) + offset) < threshold;
    if (count > best_count) best_count = count, best_normal = n, best_offset = offset;
  }
  if (best_count < 3) return std::nullopt;
  std::vector<Eigen::Vector3d> members;
  for (const Eigen::Vector3d& p : points)
    if (std::abs(best_normal.dot(p) + best_offset) < threshold) members.push_back(p);
  return fit_plane(members);
}

// A wall candidate: its point, its place on the floor's plane, how far off a wall it may lie, and the
// area it stands for (range^2: a pixel's solid angle at that range).
struct WallPoint {
  Eigen::Vector3d point;
  Eigen::Vector2d ground;
  double tolerance = 0;
  double area = 0;
  double weight() const { return 1 / (tolerance * tolerance); }  // in least squares
};

// A vertical plane as a line n . g + c = 0 on the floor's plane.
struct GroundLine {
  Eigen::Vector2d normal;
  double offset = 0;
  bool holds(const WallPoint& p) const { return std::abs(normal.dot(p.ground) + offset) < p.tolerance; }
};

// Least squares line through the points `member` marks, each weighted by its weight().
GroundLine fit_ground_line(const std::vector<WallPoint>& points, const std::vector<bool>& member) {
  double total = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i)
    if (member[i]) mean += points[i].weight() * points[i].ground, total += points[i].weight();
  mean /= total;
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i)
    if (member[i]) {
      const Eigen::Vector2d d = points[i].ground - mean;
      scatter += points[i].weight() * d * d.transpose();
    }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(scatter);
  const Eigen::Vector2d normal = solver.eigenvectors().col(0).normalized();
  return {normal, -normal.dot(mean)};
}

// The free points on `line`, and their area.
double collect(const std::vector<WallPoint>& points, const std::vector<bool>& taken, const GroundLine& line,
               std::vector<bool>& member) {
  double area = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    member[i] = !taken[i] && line.holds(points[i]);
    if (member[i]) area += points[i].area;
  }
  return area;
}

// The vertical plane holding the largest area of free points: lines through pairs of nearby
// candidates (a few samples apart in scan order, so mostly on one surface), the best refined by
// weighted least squares on its inliers. Marks its members; returns their area.
double largest_wall(const std::vector<WallPoint>& points, const std::vector<bool>& taken, int iterations,
                    std::mt19937_64& random, std::vector<bool>& member) {
  member.assign(points.size(), false);
  if (points.size() < 32) return 0;
  std::uniform_int_distribution<std::size_t> pick(0, points.size() - 1);
  std::uniform_int_distribution<std::size_t> step(3, 30);
  std::vector<bool> trial(points.size());
  GroundLine best;
  double best_area = 0;
  for (int it = 0; it < iterations; ++it) {
    const std::size_t i = pick(random), j = i + step(random);
    if (j >= points.size() || taken[i] || taken[j]) continue;
    const Eigen::Vector2d direction = points[j].ground - points[i].ground;
    if (direction.norm() < 4 * points[i].tolerance) continue;  // too short to give a direction
    const Eigen::Vector2d normal = Eigen::Vector2d(-direction.y(), direction.x()).normalized();
    const GroundLine line{normal, -normal.dot(points[i].ground)};
    if (const double area = collect(points, taken, line, trial); area > best_area)
      best_area = area, best = line;
  }
  if (best_area == 0) return 0;
  double area = collect(points, taken, best, member);
  for (int round = 0; round < 3; ++round) {
    if (std::count(member.begin(), member.end(), true) < 3) break;
    area = collect(points, taken, fit_ground_line(points, member), trial);
    std::swap(member, trial);
  }
  return area;
}

}  // namespace

PlaneFit fit_plane(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights) {
  PlaneFit fit;
  fit.inliers = points.size();
  if (points.size() < 3) return fit;
  const auto weight = [&](std::size_t i) { return weights.empty() ? 1.0 : weights[i]; };
  double total = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) mean += weight(i) * points[i], total += weight(i);
  mean /= total;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i)
    scatter += weight(i) * (points[i] - mean) * (points[i] - mean).transpose();
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
  const auto point_at = [&](int x, int y, double value) -> Eigen::Vector3d {
    return value * (map.camera.model == CameraModel::equirectangular
                        ? equirect_direction_from_pixel(depth.cols, depth.rows, Eigen::Vector2d(x, y))
                        : map.camera.unproject(Eigen::Vector2d(x, y)));
  };
  // Every second pixel is plenty for a plane and quarters the RANSAC cost.
  const double floor_cos = std::cos(options.floor_cone_deg / degrees);
  std::vector<Eigen::Vector3d> floor_points;
  for (int y = 0; y < depth.rows; y += 2)
    for (int x = 0; x < depth.cols; x += 2)
      if (const float value = depth(y, x); std::isfinite(value) && value > 0) {
        const Eigen::Vector3d point = point_at(x, y, value);
        if (point.normalized().y() > floor_cos) floor_points.push_back(point);
      }
  RoomPlanes planes;
  std::mt19937_64 random(options.seed);
  planes.floor = ransac_plane(floor_points, options.inlier_fraction * median_range(floor_points),
                              options.iterations, random);

  // Wall candidates, in scan order, placed on the floor's plane.
  const Eigen::Vector3d up = planes.floor ? planes.floor->normal : Eigen::Vector3d(0, -1, 0);
  const Eigen::Vector3d across = up.unitOrthogonal(), along = up.cross(across);
  const double wall_sin = std::sin(options.wall_band_deg / degrees);
  const double baseline = options.baseline.norm();
  // The range error of d radians of disparity is range^2 d / (baseline sin(angle to the baseline)).
  const double disparity = options.wall_disparity_px * 2 * std::numbers::pi / depth.cols;
  std::vector<WallPoint> candidates;
  for (int y = 0; y < depth.rows; y += 2)
    for (int x = 0; x < depth.cols; x += 2) {
      const float value = depth(y, x);
      if (!std::isfinite(value) || value <= 0) continue;
      WallPoint p;
      p.point = point_at(x, y, value);
      const double range = p.point.norm();
      const Eigen::Vector3d ray = p.point / range;
      if (range > options.max_wall_range || ray.dot(up) < 0 || ray.dot(up) > wall_sin ||
          p.point.dot(up) > options.max_wall_height)
        continue;
      p.ground = {p.point.dot(across), p.point.dot(along)};
      p.area = range * range;
      if (baseline > 0) {
        const double sin_to_baseline = std::max(ray.cross(options.baseline / baseline).norm(), 0.1);
        p.tolerance = disparity * p.area / (baseline * sin_to_baseline);
      }
      candidates.push_back(p);
    }
  if (baseline == 0) {
    std::vector<Eigen::Vector3d> points;
    for (const WallPoint& p : candidates) points.push_back(p.point);
    const double tolerance = options.inlier_fraction * median_range(points);
    for (WallPoint& p : candidates) p.tolerance = tolerance;
  }

  // Walls one after another, each from the candidates the previous ones did not take.
  double total_area = 0;
  for (const WallPoint& p : candidates) total_area += p.area;
  std::vector<bool> taken(candidates.size(), false), member;
  for (int w = 0; w < options.max_walls; ++w) {
    const double area = largest_wall(candidates, taken, options.iterations, random, member);
    if (area == 0 || area < options.min_wall_share * total_area) break;
    std::vector<Eigen::Vector3d> points;
    std::vector<double> weights;
    for (std::size_t i = 0; i < candidates.size(); ++i)
      if (member[i]) {
        points.push_back(candidates[i].point), taken[i] = true;
        weights.push_back(candidates[i].weight());
      }
    planes.walls.push_back(fit_plane(points, weights));
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
