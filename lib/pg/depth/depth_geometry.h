#pragma once
// Geometry of depth maps: back-projection, normals, the point cloud and the mesh of the depth grid.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pg/camera/camera.h"
#include "pg/image/depth_exr.h"
#include "pg/mesh/mesh.h"
#include "pg/mesh/point_cloud.h"

namespace pg {

// Camera-frame point of a pixel at a depth of the given kind (z or range along the ray).
Eigen::Vector3d point_from_depth(const Camera& camera, DepthKind kind, const Eigen::Vector2d& pixel,
                                 double depth);

// Depth of a camera-frame point (z or range).
double depth_of_point(DepthKind kind, const Eigen::Vector3d& point_cam);

// Camera-frame unit normals from the depth map by central differences of the back-projected points
// (one-sided where a neighbour is invalid), facing the camera; NaN where no two neighbours exist.
cv::Mat3f normals_from_depth(const cv::Mat1f& depth, const Camera& camera, DepthKind kind);

// World-frame points of the valid (finite depth, unmasked) pixels, with normals, colours from
// `image` (8-bit BGR or grey, same size; optional) and confidence when the map has them.
PointCloud depth_point_cloud(const DepthMap& map, const cv::Mat& image = {});

// Mesh of the depth grid in world coordinates: two triangles per 2x2 block of pixels, each kept when
// its three pixels are valid; facing the camera.
Mesh depth_grid_mesh(const DepthMap& map, const cv::Mat& image = {});

}  // namespace pg
