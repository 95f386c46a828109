#pragma once
// Incremental structure from motion on tracks of an ordered sequence: robust two-view initialisation,
// registration of the next frames by PnP, triangulation with angle and reprojection checks, local and
// global bundle adjustment, re-triangulation and outlier filtering between rounds.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/track/tracks.h"

namespace pg {

// How the principal point is treated when intrinsics are refined: held (fixed), refined in every
// global adjustment (refine), or freed in the final adjustment and kept only when it lowers the
// reprojection RMS by at least principal_point_min_gain (when_better: a principal point that sits
// at the image centre, as most do, is then not traded against the focal length and the poses).
enum class PrincipalPointMode { fixed, refine, when_better };

struct SfmOptions {
  // One set of intrinsics for every frame (one physical camera, self-calibration); otherwise each
  // frame keeps its own (e.g. known per-image calibrations).
  bool shared_intrinsics = true;
  bool refine_focal = true;
  PrincipalPointMode principal_point = PrincipalPointMode::fixed;
  double principal_point_min_gain = 0.005;  // when_better: relative RMS reduction that frees it
  bool refine_distortion = false;           // k1, k2
  // Observations beyond this are outliers (registration uses it throughout): about 5 sigma of SIFT
  // localisation in real photographs (RMS 0.25-0.35 px). A 4 px bound measurably lowered accuracy
  // on templeSparseRing and Herz-Jesus-P8.
  double max_reprojection_px = 1.5;
  // Once registration is over, the final rounds' bound follows the observations' noise, estimated
  // robustly after each global adjustment: bound_sigmas x sigma, within [min_reprojection_px,
  // max_reprojection_px] (0: the bound stays at max_reprojection_px); the Huber scale follows in
  // proportion (huber_px at max_reprojection_px). On sharp synthetic images SIFT observations
  // scatter about 0.02 px, and a 1.5 px bound let a tail of 0.2-1.5 px observations pull the cameras
  // (pg-synth orbit: rotation 0.044 -> 0.007 degrees). 10 sigma, not 5: localisation errors are
  // heavy-tailed, and 5 sigma cut good observations (0.088 degrees). Not during registration: the
  // observations of a frame seen across a wide baseline scatter more than the model's, and
  // templeSparseRing then registered 4 of 16 frames.
  double bound_sigmas = 10.0;
  double min_reprojection_px = 0.1;
  double min_triangulation_angle_deg = 1.5;  // points seen under a smaller angle are not kept
  double init_min_angle_deg = 3.0;           // median angle the initial pair must reach
  int min_pnp_inliers = 20;
  int local_ba_frames = 8;         // frames adjusted together after each registration
  double global_ba_growth = 1.25;  // a global adjustment whenever the model grew this much
  double huber_px = 1.0;
};

struct SfmPoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  int track = -1;
  int track_length = 0;                // observations used (registered frames within the error bound)
  double reprojection_error_px = 0;    // mean over those observations
  double triangulation_angle_deg = 0;  // largest angle between two observing rays
  std::array<std::uint8_t, 3> color{128, 128, 128};
};

struct SfmResult {
  std::vector<Camera> cameras;  // one per frame; the pose is meaningful only when registered
  std::vector<bool> registered;
  std::vector<int> frame_observations;  // observations of kept points per frame
  std::vector<double> frame_rms_px;     // their reprojection RMS
  std::vector<SfmPoint> points;
  std::vector<int> track_point;           // per track: index into points or -1
  std::vector<std::string> unregistered;  // ids of frames that could not be registered
  int initial_pair[2] = {-1, -1};
  double rms_px = 0;
  bool principal_point_refined = false;  // the principal point was freed (refine, or when_better won)
};

// `initial` holds one camera per frame of `tracks` (size, model, intrinsics guess or calibration).
// Throws UsageError when the sizes disagree, InputError naming the frames when shared intrinsics
// meet images of different sizes, FailedError (naming frames) when no pair has enough parallax or
// overlap to start from.
SfmResult reconstruct(const TrackSet& tracks, const std::vector<Camera>& initial, const SfmOptions& options);

// The default focal length guess without calibration or EXIF: 1.2 x the larger image side.
double default_focal_guess(int width, int height);

}  // namespace pg
