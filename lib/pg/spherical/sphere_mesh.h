#pragma once
// The sphere-grid mesh of a spherical range map (formats/panorama-mesh.md): one vertex per valid
// pixel at its range along its ray, two triangles per 2x2 block of valid pixels (closed across the
// longitude seam), none spanning a range discontinuity; texture coordinates into the panorama so the
// HDRI maps straight onto the mesh.
#include <opencv2/core.hpp>

#include "pg/image/depth_exr.h"
#include "pg/mesh/mesh.h"

namespace pg {

struct SphereMeshOptions {
  // A triangle is dropped when its largest range exceeds its smallest by more than this fraction.
  double max_range_jump = 0.1;
  bool world_frame = true;  // positions in the world (through the camera's pose), else the camera frame
};

// `colors` (optional): the panorama at the map's size, 8-bit or float (clipped, sRGB-encoded) BGR,
// copied to the vertex colours. Adds the vertex property "confidence" when the map has one.
// Throws UsageError for a map that is not spherical_range with an equirectangular camera.
Mesh sphere_grid_mesh(const DepthMap& map, const SphereMeshOptions& options = {}, const cv::Mat& colors = {});

}  // namespace pg
