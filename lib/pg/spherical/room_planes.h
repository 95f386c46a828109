#pragma once
// A sanity check of panorama geometry without ground truth: the floor and the largest walls as planes
// fitted (RANSAC, then least squares) to the points of a spherical range map, with their residuals
// and the angles at which they meet. A sound reconstruction of an ordinary room has a planar floor
// (small residual), walls at about 90 degrees to it and to each other (or parallel).
//
// Walls are searched for among the points above the centre (above most furniture) and near the
// horizon, as vertical planes: lines in the floor's plane, which every height of a wall votes for.
// Each wall is then fitted to its points in 3-D, so its angle to the floor is measured, not assumed.
#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "pg/image/depth_exr.h"

namespace pg {

struct PlaneFit {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();  // unit, pointing towards the camera centre
  double offset = 0;                                  // normal . p + offset = 0; the centre's distance
  std::size_t inliers = 0;
  double rms = 0;  // root mean square point-to-plane distance of the inliers, range units
};

struct RoomPlaneOptions {
  double floor_cone_deg = 50;     // floor candidates: rays within this angle of straight down (+y)
  double wall_band_deg = 35;      // wall candidates: rays within this angle above the horizon
  double max_wall_range = 6;      // wall candidates: ranges up to this (range units)
  double max_wall_height = 1.5;   // wall candidates: at most this far above the centre, below ceilings
  double inlier_fraction = 0.02;  // inlier distance as a fraction of the candidates' median range
  // The map's baseline (other centre, range units), when it comes from a panorama pair: a wall point's
  // inlier distance is then the range error of `wall_disparity_px` pixels of angular disparity, which
  // grows with the square of the range. Zero: walls use `inlier_fraction` like the floor.
  Eigen::Vector3d baseline = Eigen::Vector3d::Zero();
  double wall_disparity_px = 1.0 / 3;
  int max_walls = 4;
  double min_wall_share = 0.05;  // a wall needs this share of the candidates' area (sum of range^2)
  int iterations = 1000;
  std::uint64_t seed = 1;
};

struct RoomPlanes {
  std::optional<PlaneFit> floor;
  std::vector<PlaneFit> walls;                // largest area first; fitted in 3-D to their points
  std::vector<double> wall_floor_angles_deg;  // per wall, angle between its normal and the floor's
  std::vector<double> wall_wall_angles_deg;   // per wall pair, normals' angle folded into [0, 90]
  nlohmann::json to_json() const;
};

// The map's camera frame: x right, y down (the panorama must be upright). Deterministic for a seed.
RoomPlanes fit_room_planes(const DepthMap& map, const RoomPlaneOptions& options = {});

// Least-squares plane through points, optionally weighted (normal towards the origin); rms over all of
// them, unweighted.
PlaneFit fit_plane(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights = {});

}  // namespace pg
