#pragma once
// Surfaces from point clouds (sparse points from pg-track, scans without a sensor origin):
// normals after Hoppe et al. 1992, orientation over a minimum spanning tree, facing the cameras that
// see the points, and screened Poisson reconstruction (Kazhdan 2006/2013) on an OpenVDB sparse grid.
#include <Eigen/Core>
#include <vector>

#include "pg/camera/cameras_io.h"
#include "pg/mesh/mesh.h"
#include "pg/mesh/point_cloud.h"

namespace pg::fusion {

struct PointSurfaceOptions {
  double voxel_size = 0;      // Poisson grid spacing, scene units (about twice the point spacing)
  int neighbours = 10;        // k of the k-nearest-neighbour plane fits and of the spanning tree graph
  double trim_density = 0.1;  // drop vertices whose point density is below this fraction of the median
  double screening = 4.0;     // pull of the surface towards the points (0 = plain Poisson)
  int band = 4;               // the grid covers voxels within this many voxels of a point
  double base_weight = 0.05;  // weight of base-surface samples relative to a point
};

// Unit normals of planes fitted to each point's k nearest neighbours (smallest principal axis);
// unoriented. Needs at least 3 points.
std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3f>& points, int k);

// Makes neighbouring normals consistent by propagating flips over a minimum spanning tree of the
// k-nearest-neighbour graph (edge cost 1 - |n_i . n_j|). Each connected piece is then turned so
// that most of its normals face the cameras that see its points (in front, inside the image, not
// hidden behind nearer points of the cloud), or,
// without cameras, so that its highest point's normal has positive z (Hoppe's choice).
void orient_normals(const std::vector<Eigen::Vector3f>& points, std::vector<Eigen::Vector3f>& normals, int k,
                    const CameraSet* cameras);

// Screened Poisson surface of oriented points (weights empty = all 1): the indicator's zero level
// set, only where the grid was solved, vertices trimmed by density. Adds the vertex property
// "density". Throws FailedError for fewer than 3 points.
Mesh poisson_surface(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& normals,
                     const std::vector<float>& weights, const PointSurfaceOptions& options);

// The whole path: normals (estimated unless the cloud has them), orientation, optional base surface
// samples (filling where there are no points), Poisson.
Mesh surface_from_points(const PointCloud& cloud, const CameraSet* cameras, const Mesh* base,
                         const PointSurfaceOptions& options);

}  // namespace pg::fusion
