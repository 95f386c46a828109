// bench_remesh: pg::remesh against CGAL::Polygon_mesh_processing::isotropic_remeshing on the
// Stanford bunny, at the same target length L (the mean input edge length unless --scale says
// otherwise), iterations and feature angle; prints time, ratio, and quality (edges within
// [0.8, 1.33] L, triangles with minimum angle above 30 degrees, valence 6, Hausdorff distance / L, over
// the whole bunny and over its smooth region, pg::smooth_vertices with radius factor 3).
//   bench_remesh [--data DIR] [--iterations N] [--scale S] [--threads T]
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/detect_features.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "pg/build_info.h"
#include "pg/core/parallel.h"
#include "pg/mesh/mesh_io.h"
#include "pg/remesh/quality.h"
#include "pg/remesh/remesh.h"

namespace fs = std::filesystem;
namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;

namespace {

SurfaceMesh to_cgal(const pg::Mesh& mesh) {
  SurfaceMesh out;
  std::vector<SurfaceMesh::Vertex_index> v;
  for (const auto& p : mesh.positions) v.push_back(out.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z())));
  for (const auto& f : mesh.faces) out.add_face(v[f[0]], v[f[1]], v[f[2]]);
  return out;
}

pg::Mesh from_cgal(const SurfaceMesh& mesh) {
  pg::Mesh out;
  std::vector<std::uint32_t> index(mesh.number_of_vertices() + mesh.number_of_removed_vertices());
  for (const auto v : mesh.vertices()) {
    index[v] = std::uint32_t(out.positions.size());
    const auto& p = mesh.point(v);
    out.positions.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  for (const auto f : mesh.faces()) {
    std::array<std::uint32_t, 3> face;
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) face[k++] = index[v];
    out.faces.push_back(face);
  }
  return out;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

struct Row {
  std::string name;
  double seconds;
  pg::Mesh mesh;
};

void print_row(const Row& row, const pg::Mesh& input, float length) {
  const pg::MeshQuality q =
      pg::measure_quality(row.mesh, {}, std::vector<float>(row.mesh.vertex_count(), length));
  const pg::HausdorffDistance h = pg::hausdorff_distance(row.mesh, {}, input, {}, 0.25f * length);
  const pg::SmoothRegionHausdorff s =
      pg::smooth_region_hausdorff(row.mesh, input, {}, length, 3, 0.25f * length);
  std::printf("%-26s %8.3f s %8zu faces %8.4f %8.4f %8.4f %8.1f %8.4f %8.4f\n", row.name.c_str(), row.seconds,
              row.mesh.face_count(), q.edges_in_range, q.angles_above_30, q.valence_6, q.smallest_angle_deg,
              h.distance / length, s.hausdorff.distance / length);
}

}  // namespace

int main(int argc, char** argv) {
  fs::path data = pg::build_info::default_data_dir;
  if (const char* env = std::getenv("PG_DATA_DIR")) data = env;
  int iterations = 10, threads = 0;
  float scale = 1.0f, feature_angle = 45.0f;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--data" && i + 1 < argc)
      data = argv[++i];
    else if (arg == "--iterations" && i + 1 < argc)
      iterations = std::atoi(argv[++i]);
    else if (arg == "--scale" && i + 1 < argc)
      scale = float(std::atof(argv[++i]));
    else if (arg == "--threads" && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: bench_remesh [--data DIR] [--iterations N] [--scale S] [--threads T]\n");
      return 2;
    }
  }
  const fs::path path = data / "meshes/stanford-bunny/reconstruction/bun_zipper.ply";
  if (!fs::exists(path)) {
    std::fprintf(stderr, "bench_remesh: %s not found (set PG_DATA_DIR or --data)\n", path.string().c_str());
    return 3;
  }
  pg::set_thread_count(threads);

  // Both remeshers get the bunny without its unused vertices.
  pg::RemeshOptions options;
  options.iterations = 0;
  const pg::Mesh input = pg::remesh(pg::read_mesh(path), options).input;
  const float length = scale * pg::mean_edge_length(input);
  options.iterations = iterations;
  options.target_length = length;
  options.feature_angle_deg = feature_angle;

  std::printf(
      "Stanford bunny: %zu vertices, %zu faces; L = %.6g (%.2f x mean edge), %d iterations, features above "
      "%.0f degrees, %d threads for pg\n",
      input.vertex_count(), input.face_count(), length, scale, iterations, feature_angle, pg::thread_count());
  const std::vector<bool> smooth = pg::faces_within(input, pg::smooth_vertices(input, length, 3));
  const double smooth_fraction =
      double(std::count(smooth.begin(), smooth.end(), true)) / double(smooth.size());
  std::printf(
      "smooth region (curvature radius of at least 3 L within L of every vertex, off the boundary): %.1f%% "
      "of the faces\n",
      100 * smooth_fraction);
  std::printf("%-26s %10s %14s %8s %8s %8s %8s %8s %8s\n", "", "time", "", "edges", "angle>30", "val6",
              "min ang", "H / L", "smooth");

  auto start = std::chrono::steady_clock::now();
  pg::RemeshResult ours = pg::remesh(input, options);
  const Row pg_row{"pg::remesh", seconds_since(start), std::move(ours.mesh)};

  SurfaceMesh cgal = to_cgal(input);
  start = std::chrono::steady_clock::now();
  auto constrained = cgal.add_property_map<SurfaceMesh::Edge_index, bool>("e:constrained", false).first;
  PMP::detect_sharp_edges(cgal, feature_angle, constrained);
  PMP::isotropic_remeshing(faces(cgal), double(length), cgal,
                           PMP::parameters::number_of_iterations(iterations)
                               .edge_is_constrained_map(constrained)
                               .protect_constraints(false)
                               .relax_constraints(true));
  const Row cgal_row{"CGAL isotropic_remeshing", seconds_since(start), from_cgal(cgal)};

  print_row({"input", 0.0, input}, input, length);
  print_row(pg_row, input, length);
  print_row(cgal_row, input, length);
  std::printf("time ratio CGAL / pg: %.2f (above 1: pg is faster)\n", cgal_row.seconds / pg_row.seconds);
  return 0;
}
