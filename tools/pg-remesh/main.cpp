// pg-remesh: isotropic remeshing of a mesh or of the region a mask or a deformation selects, features
// and pinned vertices kept, masks carried to the new topology (formats/remesh-report.md).
#include <algorithm>
#include <filesystem>
#include <iostream>

#include "common/cli.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/provenance.h"
#include "pg/core/run_report.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/vertex_mask.h"
#include "pg/remesh/region.h"
#include "pg/remesh/remesh.h"
#include "pg/remesh/remesh_report.h"

namespace fs = std::filesystem;

namespace {

struct Files {
  std::string in, out, quality_report, histogram;
  std::string mask, deformed_from, pinned;
  std::vector<std::string> carry;
  std::string region_property, pinned_property = "pinned";
  float tolerance = 0;
  int grow = 1;
};

// Reads a mask, checks it belongs to `mesh` and stores it as the vertex property of its name.
pg::VertexMask attach_mask(pg::Mesh& mesh, const std::string& path) {
  pg::VertexMask mask = pg::read_vertex_mask(path);
  pg::check_fits(mask, mesh, path);
  pg::set_property_from_mask(mesh, mask);
  return mask;
}

std::vector<bool> property_selection(const pg::Mesh& mesh, const std::string& name, const std::string& in) {
  const auto it = mesh.vertex_properties.find(name);
  if (it == mesh.vertex_properties.end() || it->second.empty())
    throw pg::InputError(in, "has no vertex property \"" + name + "\"");
  return pg::selected_vertices(it->second);
}

fs::path mask_output_path(const fs::path& out, const std::string& name) {
  return out.parent_path() / (out.stem().string() + "." + name + ".pgmask.json");
}

}  // namespace

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-remesh", "isotropic remeshing of the deformed region of a mesh, features and pinned vertices kept",
       "pg-remesh --in refined.ply --out remeshed.ply --deformed-from before.ply --grow 2 \\\n"
       "    --pinned pinned.pgmask.json --quality-report remesh.json --histogram remesh.png\n"
       "pg-remesh --in scan.ply --out scan-remeshed.ply --target-length 0.002 --iterations 10"});
  CLI::App& app = frame.app();
  Files f;
  pg::RemeshOptions o;
  app.add_option("--in", f.in, "mesh to remesh (PLY or OBJ)")->required();
  app.add_option("--out", f.out, "remeshed mesh (PLY keeps the vertex properties; OBJ drops them)")
      ->required();
  app.add_option("--target-length", o.target_length,
                 "target edge length L (default: mean edge length of the region)")
      ->check(pg::cli::non_negative());
  app.add_option("--iterations", o.iterations, "split / collapse / flip / relax rounds")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--feature-angle", o.feature_angle_deg,
                 "dihedral angle in degrees above which an edge is a feature")
      ->capture_default_str()
      ->check(CLI::Range(0.0f, 180.0f));
  app.add_flag("--adaptive", o.adaptive, "shorter edges where curvature is high");
  app.add_option("--approx-error", o.approximation_error, "adaptive: chord error to aim for (default 0.05 L)")
      ->check(pg::cli::non_negative());
  app.add_option("--min-length", o.min_length, "adaptive: shortest target (default 0.25 L)")
      ->check(pg::cli::non_negative());
  app.add_option("--max-length", o.max_length, "adaptive: longest target (default 2 L)")
      ->check(pg::cli::non_negative());
  app.add_option("--mask", f.mask,
                 "remesh only where this vertex mask is above zero (e.g. working_set.pgmask.json)");
  app.add_option("--region-property", f.region_property,
                 "remesh only where this vertex property of --in is above zero");
  app.add_option("--deformed-from", f.deformed_from,
                 "remesh only the vertices that moved against this mesh (same topology)");
  app.add_option("--tolerance", f.tolerance, "--deformed-from: a vertex moved when it is farther than this")
      ->capture_default_str()
      ->check(pg::cli::non_negative());
  app.add_option("--grow", f.grow, "grow the region by this many rings of neighbours")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--pinned", f.pinned, "vertex mask of vertices to keep exactly (above zero = pinned)");
  app.add_option("--pinned-property", f.pinned_property,
                 "vertex property of --in naming pinned vertices, used when present and no --pinned is given")
      ->capture_default_str();
  app.add_option("--carry-mask", f.carry, "further vertex masks to carry to the new mesh (repeatable)");
  app.add_option("--quality-report", f.quality_report,
                 "write the remeshing report (JSON, format pg-remesh-report)");
  app.add_option("--histogram", f.histogram, "write the quality histograms before / after as a PNG");

  return frame.run(argc, argv, [&] {
    frame.input(f.in);
    for (const std::string& path : {f.mask, f.deformed_from, f.pinned})
      if (!path.empty()) frame.input(path);
    for (const std::string& path : f.carry) frame.input(path);
    frame.output(f.out);
    if (!f.quality_report.empty()) frame.output(f.quality_report);
    if (!f.histogram.empty()) frame.output(f.histogram);
    const int region_sources = !f.mask.empty() + !f.region_property.empty() + !f.deformed_from.empty();
    if (region_sources > 1)
      throw pg::UsageError("give at most one of --mask, --region-property and --deformed-from");

    pg::Mesh mesh = pg::read_mesh(f.in);
    o.input_name = f.in;
    std::vector<std::string> mask_names;
    std::string region_source = "whole mesh";
    if (!f.mask.empty()) {
      const pg::VertexMask mask = attach_mask(mesh, f.mask);
      o.region = pg::selected_vertices(mask.weights);
      mask_names.push_back(mask.name);
      region_source = "mask " + f.mask;
    } else if (!f.region_property.empty()) {
      o.region = property_selection(mesh, f.region_property, f.in);
      region_source = "property " + f.region_property;
    } else if (!f.deformed_from.empty()) {
      o.region = pg::deformed_vertices(mesh, pg::read_mesh(f.deformed_from), f.tolerance, f.deformed_from);
      region_source = pg::str("deformed from ", f.deformed_from, " (tolerance ", f.tolerance, ")");
    }
    if (!o.region.empty()) {
      const auto moved = std::count(o.region.begin(), o.region.end(), true);
      o.region = pg::grow_region(mesh, o.region, f.grow);
      region_source += pg::str(", grown by ", f.grow, " ring", f.grow == 1 ? "" : "s");
      pg::log::info("region: ", moved, " vertices selected, ",
                    std::count(o.region.begin(), o.region.end(), true), " after growing by ", f.grow);
    }
    if (!f.pinned.empty()) {
      const pg::VertexMask mask = attach_mask(mesh, f.pinned);
      o.pinned = pg::selected_vertices(mask.weights);
      mask_names.push_back(mask.name);
    } else if (mesh.vertex_properties.count(f.pinned_property) &&
               !mesh.vertex_properties[f.pinned_property].empty()) {
      o.pinned = pg::selected_vertices(mesh.vertex_properties[f.pinned_property]);
      pg::log::info("pinning the vertices of property \"", f.pinned_property, "\" of ", f.in);
    }
    for (const std::string& path : f.carry) mask_names.push_back(attach_mask(mesh, path).name);
    // One output per mask name (a mask given as --mask and --carry-mask is written once), declared
    // before the remeshing so that a clash fails at once.
    std::vector<std::string> unique_names;
    for (const std::string& name : mask_names)
      if (std::find(unique_names.begin(), unique_names.end(), name) == unique_names.end())
        unique_names.push_back(name);
    mask_names = unique_names;
    for (const std::string& name : mask_names) frame.output(mask_output_path(f.out, name));

    pg::RemeshResult result;
    {
      pg::ScopedTimer timer("remesh");
      result = pg::remesh(mesh, o);
    }
    result.mesh.provenance = pg::Provenance::current();

    // The mesh is written last: a run killed part-way never leaves it beside a missing mask or
    // report, so a Make rule that goes by the mesh reruns the step.
    pg::RemeshReportFiles files{f.in, f.out, region_source, {}};
    for (const std::string& name : mask_names) {
      const fs::path path = mask_output_path(f.out, name);
      pg::VertexMask mask = pg::mask_from_property(result.mesh, name);
      mask.provenance = pg::Provenance::current();
      pg::write_vertex_mask(path, mask);
      files.masks_written.push_back(path.string());
    }

    pg::RemeshEvaluation evaluation;
    {
      pg::ScopedTimer timer("evaluate");
      evaluation = pg::evaluate_remesh(result);
    }
    if (!f.quality_report.empty())
      pg::write_remesh_report(f.quality_report, pg::remesh_report_json(result, o, evaluation, files));
    if (!f.histogram.empty()) pg::write_quality_png(f.histogram, evaluation);
    pg::write_mesh(f.out, result.mesh);

    const pg::RemeshStats& s = result.stats;
    pg::RunReport& report = pg::RunReport::global();
    report.set_metric("target_length", result.target_length);
    report.set_metric("region_vertices", s.region_vertices);
    report.set_metric("unused_vertices_dropped", s.unused_vertices_dropped);
    report.set_metric("output_vertices", result.mesh.vertex_count());
    report.set_metric("output_faces", result.mesh.face_count());
    report.set_metric("edges_within_0.8_1.33", evaluation.after.edges_in_range);
    report.set_metric("min_angle_above_30", evaluation.after.angles_above_30);
    report.set_metric("valence_6", evaluation.after.valence_6);
    report.set_metric("hausdorff", evaluation.hausdorff.distance);
    report.set_metric("hausdorff_relative_to_target", evaluation.hausdorff.distance / result.target_length);
    report.set_metric("hausdorff_smooth_relative_to_target",
                      evaluation.smooth_hausdorff.hausdorff.distance / result.target_length);
    report.set_metric("smooth_fraction", evaluation.smooth_hausdorff.input_fraction);
    std::cout << pg::str("remeshed ", s.region_vertices, " region vertices at L = ", result.target_length,
                         ": ", result.mesh.vertex_count(), " vertices, ", result.mesh.face_count(),
                         " faces; edges within [0.8, 1.33] L ", evaluation.before.edges_in_range, " -> ",
                         evaluation.after.edges_in_range, ", min angle above 30 degrees ",
                         evaluation.before.angles_above_30, " -> ", evaluation.after.angles_above_30,
                         ", Hausdorff ", evaluation.hausdorff.distance, " (",
                         evaluation.hausdorff.distance / result.target_length, " L; ",
                         evaluation.smooth_hausdorff.hausdorff.distance / result.target_length,
                         " L where smooth)")
              << "\n";
  });
}
