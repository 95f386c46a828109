// Screened Poisson reconstruction on a sparse OpenVDB grid: the oriented points are splatted into a
// vector field V, and the indicator chi with Laplacian(chi) = div(V), pulled towards 0 at the points,
// is solved by conjugate gradients on the voxels within a band of the points (zero-flux boundary).
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/fusion/mesh_cleanup.h"
#include "pg/fusion/point_surface.h"
#include "pg/fusion/tsdf_grids.h"

namespace pg::fusion {
namespace {

using openvdb::Coord;

// The voxels of the solve and their face neighbours (-1 outside the band).
struct Domain {
  openvdb::Int32Grid::Ptr index;  // voxel -> row, active on the band
  std::vector<Coord> voxels;
  std::vector<std::array<int, 6>> neighbours;
};

Domain make_domain(const std::vector<Eigen::Vector3f>& points, double inverse_voxel, int band) {
  openvdb::MaskTree mask;
  for (const auto& p : points) {
    const Coord base(int(std::floor(p.x() * inverse_voxel)), int(std::floor(p.y() * inverse_voxel)),
                     int(std::floor(p.z() * inverse_voxel)));
    for (int corner = 0; corner < 8; ++corner)
      mask.setValueOn(base.offsetBy(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1));
  }
  openvdb::tools::dilateActiveValues(mask, band, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                     openvdb::tools::IGNORE_TILES);
  Domain d;
  d.index = openvdb::Int32Grid::create(-1);
  d.index->tree().topologyUnion(mask);
  auto accessor = d.index->getAccessor();
  for (auto v = d.index->tree().beginValueOn(); v; ++v) {
    v.setValue(int(d.voxels.size()));
    d.voxels.push_back(v.getCoord());
  }
  d.neighbours.resize(d.voxels.size());
  static const Coord steps[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (std::size_t i = 0; i < d.voxels.size(); ++i)
    for (int s = 0; s < 6; ++s) {
      const Coord c = d.voxels[i] + steps[s];
      d.neighbours[i][s] = accessor.isValueOn(c) ? accessor.getValue(c) : -1;
    }
  return d;
}

// Visits the 8 voxels around index-space point p with their trilinear weights.
template <class Visit>
void for_corners(const Eigen::Vector3d& p, Visit&& visit) {
  const Eigen::Vector3d floor(std::floor(p.x()), std::floor(p.y()), std::floor(p.z()));
  const Eigen::Vector3d f = p - floor;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const double w = (dx ? f.x() : 1 - f.x()) * (dy ? f.y() : 1 - f.y()) * (dz ? f.z() : 1 - f.z());
    visit(Coord(int(floor.x()) + dx, int(floor.y()) + dy, int(floor.z()) + dz), w);
  }
}

// The deterministic reduce splits the range the same way whatever the threads or their timing, so
// the sum (and the surface) is the same on every run; parallel_reduce's splits follow work stealing.
double dot(const std::vector<double>& a, const std::vector<double>& b) {
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, a.size(), 4096), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double sum) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) sum += a[i] * b[i];
        return sum;
      },
      std::plus<>());
}

// Solves (-L + S) x = rhs by Jacobi-preconditioned conjugate gradients; L the graph Laplacian with
// unit spacing over the domain's face neighbours, S = diag(screen).
std::vector<double> solve(const Domain& d, const std::vector<double>& screen,
                          const std::vector<double>& rhs) {
  const std::size_t n = d.voxels.size();
  auto apply = [&](const std::vector<double>& x, std::vector<double>& y) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                          double v = screen[i] * x[i];
                          for (int s = 0; s < 6; ++s)
                            if (const int j = d.neighbours[i][s]; j >= 0) v += x[i] - x[j];
                          y[i] = v;
                        }
                      });
  };
  std::vector<double> inverse_diagonal(n);
  for (std::size_t i = 0; i < n; ++i) {
    int count = 0;
    for (int s = 0; s < 6; ++s) count += d.neighbours[i][s] >= 0;
    inverse_diagonal[i] = 1.0 / std::max(1e-12, count + screen[i]);
  }
  std::vector<double> x(n, 0.0), r = rhs, z(n), p(n), q(n);
  for (std::size_t i = 0; i < n; ++i) z[i] = inverse_diagonal[i] * r[i];
  p = z;
  double rz = dot(r, z);
  const double tolerance = 1e-7 * std::sqrt(std::max(dot(rhs, rhs), 1e-300));
  int iteration = 0;
  for (; iteration < 2000 && std::sqrt(dot(r, r)) > tolerance; ++iteration) {
    apply(p, q);
    const double alpha = rz / dot(p, q);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * q[i];
      z[i] = inverse_diagonal[i] * r[i];
    }
    const double rz_next = dot(r, z);
    const double beta = rz_next / rz;
    rz = rz_next;
    for (std::size_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
  }
  log::debug("poisson: ", n, " unknowns, ", iteration, " CG iterations");
  return x;
}

}  // namespace

Mesh poisson_surface(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& normals,
                     const std::vector<float>& weights, const PointSurfaceOptions& options) {
  if (points.size() < 3) throw FailedError("a Poisson surface needs at least 3 points");
  if (!(options.voxel_size > 0)) throw UsageError("the Poisson voxel size must be positive");
  initialize_openvdb();
  const double inverse_voxel = 1.0 / options.voxel_size;
  const Domain d = make_domain(points, inverse_voxel, std::max(1, options.band));
  const std::size_t n = d.voxels.size();
  const auto index = d.index->getConstAccessor();

  // Splat: density D and field V (in units where the voxel is 1).
  std::vector<double> density(n, 0.0);
  std::vector<Eigen::Vector3d> field(n, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    for_corners(points[i].cast<double>() * inverse_voxel, [&](const Coord& c, double t) {
      const int row = index.getValue(c);
      density[row] += w * t;
      field[row] += w * t * normals[i].cast<double>();
    });
  }
  std::vector<double> occupied;
  for (double v : density)
    if (v > 0) occupied.push_back(v);
  std::nth_element(occupied.begin(), occupied.begin() + occupied.size() / 2, occupied.end());
  const double median_density = occupied[occupied.size() / 2];
  // Scale V so that a surface sampled at the median density makes the indicator jump by about 1.
  for (auto& v : field) v /= median_density;

  // rhs = -div V (central differences), screen = alpha D / median D.
  std::vector<double> rhs(n, 0.0), screen(n);
  for (std::size_t i = 0; i < n; ++i) {
    double divergence = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const int plus = d.neighbours[i][2 * axis], minus = d.neighbours[i][2 * axis + 1];
      divergence += 0.5 * ((plus >= 0 ? field[plus][axis] : 0.0) - (minus >= 0 ? field[minus][axis] : 0.0));
    }
    rhs[i] = -divergence;
    screen[i] = options.screening * density[i] / median_density;
  }
  const std::vector<double> chi = solve(d, screen, rhs);

  // The indicator on the grid; outside the band the background is positive (outside), but cells
  // that leave the band are not meshed.
  auto grid = openvdb::FloatGrid::create(1e6f);
  grid->setGridClass(openvdb::GRID_LEVEL_SET);  // negative inside: volumeToMesh winds by the class
  grid->setTransform(openvdb::math::Transform::createLinearTransform(options.voxel_size));
  grid->tree().topologyUnion(d.index->tree());
  {
    auto accessor = grid->getAccessor();
    for (std::size_t i = 0; i < n; ++i) accessor.setValueOn(d.voxels[i], float(chi[i]));
  }
  std::vector<openvdb::Vec3s> vertices;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, vertices, triangles, quads, 0.0, 0.0);
  const auto faces = triangles_from(vertices, triangles, quads);

  auto density_grid = openvdb::FloatGrid::create(0.0f);
  density_grid->tree().topologyUnion(d.index->tree());
  {
    auto accessor = density_grid->getAccessor();
    for (std::size_t i = 0; i < n; ++i) accessor.setValueOn(d.voxels[i], float(density[i]));
  }
  const auto density_accessor = density_grid->getConstAccessor();
  std::vector<float> vertex_density(vertices.size(), 0.0f);
  std::vector<char> inside(vertices.size(), 0);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const openvdb::Vec3d p = openvdb::Vec3d(vertices[i]) * inverse_voxel;
    inside[i] = cell_is_active(density_accessor, p);
    vertex_density[i] = openvdb::tools::BoxSampler::sample(density_accessor, p);
  }
  std::vector<float> kept_density;
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (inside[i]) kept_density.push_back(vertex_density[i]);
  float threshold = 0;
  if (!kept_density.empty()) {
    std::nth_element(kept_density.begin(), kept_density.begin() + kept_density.size() / 2,
                     kept_density.end());
    threshold = float(options.trim_density) * kept_density[kept_density.size() / 2];
  }

  Mesh mesh;
  mesh.positions.reserve(vertices.size());
  for (const auto& v : vertices) mesh.positions.emplace_back(v.x(), v.y(), v.z());
  mesh.vertex_properties["density"] = vertex_density;
  auto keep = [&](std::uint32_t v) { return inside[v] && vertex_density[v] >= threshold; };
  for (const auto& f : faces)
    if (keep(f[0]) && keep(f[1]) && keep(f[2])) mesh.faces.push_back(f);
  remove_unused_vertices(mesh);
  return mesh;
}

Mesh surface_from_points(const PointCloud& cloud, const CameraSet* cameras, const Mesh* base,
                         const PointSurfaceOptions& options) {
  std::vector<Eigen::Vector3f> points = cloud.positions;
  std::vector<Eigen::Vector3f> normals = cloud.normals;
  if (normals.empty()) {
    normals = estimate_normals(points, options.neighbours);
    orient_normals(points, normals, options.neighbours, cameras);
  }
  std::vector<float> weights(points.size(), 1.0f);
  if (base) {
    // Base-surface samples about half a voxel apart, at low weight: they only decide where points are
    // missing.
    const double spacing = options.voxel_size / 2;
    for (const auto& f : base->faces) {
      const Eigen::Vector3f a = base->positions[f[0]], b = base->positions[f[1]], c = base->positions[f[2]];
      const Eigen::Vector3f n = (b - a).cross(c - a);
      if (!(n.norm() > 0)) continue;
      const int steps =
          std::max(1, int(std::ceil(std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / spacing)));
      for (int i = 0; i <= steps; ++i)
        for (int j = 0; i + j <= steps; ++j) {
          points.push_back(a + (b - a) * (float(i) / steps) + (c - a) * (float(j) / steps));
          normals.push_back(n.normalized());
          weights.push_back(float(options.base_weight));
        }
    }
  }
  return poisson_surface(points, normals, weights, options);
}

}  // namespace pg::fusion
