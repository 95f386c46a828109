#pragma once
// Bundle adjustment with Ceres: camera poses, 3D points and optionally intrinsics (focal length,
// principal point, radial k1 k2) minimise the robust reprojection error. SPARSE_SCHUR with
// SuiteSparse, Huber loss. Single-threaded: Ceres' threaded evaluation and Schur elimination sum
// shared blocks in scheduling order, so results would change in the last bits with the thread count.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace pg {

// Pose as angle-axis rotation then translation (cam_from_world).
using PoseParams = std::array<double, 6>;
// f, cx, cy, k1, k2; fy = f * aspect (aspect fixed per intrinsics group).
using IntrinsicParams = std::array<double, 5>;

struct BundleObservation {
  int frame = 0, point = 0;
  Eigen::Vector2d pixel;
};

struct BundleProblem {
  std::vector<PoseParams>* poses = nullptr;            // one per frame
  std::vector<IntrinsicParams>* intrinsics = nullptr;  // one per intrinsics group
  std::vector<double> aspect;                          // fy / fx per group
  std::vector<int> frame_group;                        // intrinsics group of each frame
  std::vector<Eigen::Vector3d>* points = nullptr;
  std::vector<BundleObservation> observations;
  std::vector<bool>
      frame_constant;  // poses held fixed (others free); frames without observations are ignored
  std::vector<bool> point_constant;  // empty: all points free
  // Fixes the scale gauge: this free frame keeps translation component `scale_axis` (-1: none).
  int scale_frame = -1;
  int scale_axis = 0;
};

struct BundleOptions {
  bool refine_focal = false;
  bool refine_principal_point = false;
  bool refine_distortion = false;  // k1, k2
  double huber_px = 1.0;
  int max_iterations = 50;
  double function_tolerance = 1e-7;
};

struct BundleSummary {
  double initial_rms_px = 0, final_rms_px = 0;
  int iterations = 0;
  bool converged = false;
};

BundleSummary bundle_adjust(BundleProblem& problem, const BundleOptions& options);

// Reprojection of a world point through pose + intrinsics; false when behind the camera.
bool project_with_params(const PoseParams& pose, const IntrinsicParams& intrinsics, double aspect,
                         const Eigen::Vector3d& point, Eigen::Vector2d& pixel);

}  // namespace pg
