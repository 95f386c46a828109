#pragma once
// The inputs of one merge, listed first and loaded one at a time (so memory holds one input, not
// all): pg depth EXRs, RGB-D depth images with a camera, and range scans (formats/rgbd-inputs.md).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pg/fusion/tsdf_volume.h"

namespace pg::fusion {

enum class InputKind { depth_exr, rgbd, scan };

struct MergeInput {
  InputKind kind = InputKind::depth_exr;
  std::filesystem::path path;   // depth EXR, RGB-D depth image, or scan mesh / range grid / points
  std::filesystem::path color;  // optional colour image (depth EXR, RGB-D)
  std::filesystem::path mask;   // optional user mask image, nonzero = ignore (depth EXR, RGB-D)
  Camera camera;                // RGB-D: the depth image's camera
  Rigid3 world_from_scan;       // scan: its placement
  std::optional<Eigen::Vector3d> sensor_origin, sensor_direction;  // scan: in the scan's frame
  double multiplier = 1.0;                                         // per-input weight factor
};

struct InputSettings {
  WeightOptions weights;         // multiplier is taken from each MergeInput
  double depth_scale = 0.001;    // RGB-D: scene units per depth-image unit
  double max_edge_factor = 4.0;  // range grids: longest edge kept, in median grid spacings
};

// Loads one input and integrates it; a scan file holding only vertices is integrated as points
// (inspect_scan). Throws InputError naming the file at fault.
void integrate_input(TsdfVolume& volume, const MergeInput& input, const InputSettings& settings);

// Loads a depth EXR or RGB-D input as a frame (for checks such as depth agreement).
DepthFrame load_frame(const MergeInput& input, const InputSettings& settings);

}  // namespace pg::fusion
