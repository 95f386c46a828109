#pragma once
// Range maps from a pair of equirectangular panoramas (pg-sphdepth): both spheres are rotated so
// that the baseline is the polar axis, the flow engine's epipolar mode solves the 1-D disparity along
// the meridians (longitude seam handled by wrap-around padding), ranges follow by triangulation on the
// sphere, and the map is rotated back into the reference panorama.
#include <Eigen/Core>
#include <cstddef>
#include <opencv2/core.hpp>

#include "pg/camera/camera.h"
#include "pg/flow/flow.h"
#include "pg/image/depth_exr.h"

namespace pg {

struct SphereDepthOptions {
  FlowOptions flow = FlowOptions::preset("balanced");
  // Output (and computation) size relative to the reference panorama, in (0, 1].
  double scale = 1.0;
  // Pixels within this angle (degrees) of either end of the baseline axis are invalid: the disparity
  // vanishes there and the range is undetermined.
  double pole_band_deg = 10.0;
  // Forward-backward consistency limit in rectified pixels: beyond it a pixel is invalid (occluded or
  // mismatched); below it the confidence falls linearly with the error.
  double max_fb_error = 0.5;
  // Columns copied across the longitude seam on each side before solving, as a fraction of the width.
  double seam_padding = 0.0625;
  // Ranges beyond this are invalid (0 = no limit), in baseline units.
  double max_range = 0.0;
  // Keep every triangulated range; rejections only zero the confidence.
  bool keep_all = false;
  // Pixels failing the forward-backward check take the background of their meridian (the smaller
  // disparity of the nearest consistent pixels either way along it, fill_occlusions_along_lines): a
  // point hidden from the other centre lies behind the nearer surface beside it. The pole bands are
  // never a source. Filled pixels carry half a consistent pixel's confidence.
  bool fill_occlusions = false;

  void check() const;  // throws UsageError naming the first invalid field
};

// Two panoramas of the same size and channel count (8-bit, 16-bit or float HDR; float input is
// matched in the log domain) and the pose of the second in the first's camera frame.
struct SpherePair {
  cv::Mat reference, other;
  Camera reference_camera;  // equirectangular, the reference image's size; its pose goes to the output
  Eigen::Vector3d baseline = Eigen::Vector3d::Zero();                  // other centre in the reference frame
  Eigen::Matrix3d other_from_reference = Eigen::Matrix3d::Identity();  // rotation between the frames
};

struct SphereDepthResult {
  DepthMap map;         // spherical_range in the reference camera (scaled size), confidence in [0, 1]
  cv::Mat1f disparity;  // angular disparity (radians) per output pixel, NaN where not solved
  // `filled`: valid pixels that failed the forward-backward check and took their meridian's background.
  std::size_t valid = 0, filled = 0, pole_band = 0, inconsistent = 0, untriangulated = 0, too_far = 0;
  double flow_seconds = 0, triangulation_seconds = 0;
  double valid_fraction() const { return map.depth.empty() ? 0.0 : double(valid) / map.depth.total(); }
};

// Throws UsageError for empty or mismatched images, a non-equirectangular reference camera, a size
// that disagrees with the camera, a zero baseline or invalid options.
SphereDepthResult compute_sphere_depth(const SpherePair& pair, const SphereDepthOptions& options = {});

// Angle (radians) between the ray of output pixel (x, y) and the baseline direction.
double polar_angle_from_baseline(int width, int height, int x, int y, const Eigen::Vector3d& baseline);

}  // namespace pg
