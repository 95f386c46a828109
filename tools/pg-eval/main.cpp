// pg-eval: evaluates a stage's output against ground truth (formats/eval-report.md).
#include <iostream>

#include "common/cli.h"
#include "pg/camera/cameras_io.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"
#include "pg/eval/camera_eval.h"
#include "pg/eval/depth_eval.h"
#include "pg/eval/eval_report.h"
#include "pg/eval/flo_io.h"
#include "pg/eval/flow_eval.h"
#include "pg/eval/mesh_eval.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"

namespace fs = std::filesystem;

namespace {

struct Common {
  std::string estimate, truth, out;
};

void add_common(CLI::App& command, Common& c, const std::string& what) {
  command.add_option("--estimate", c.estimate, "the " + what + " to evaluate")->required();
  command.add_option("--truth", c.truth, "the ground-truth " + what)->required();
  command.add_option("--out", c.out, "write the result JSON (format pg-eval) here");
}

void declare_files(pg::cli::Frame& frame, const Common& c) {
  frame.input(c.estimate);
  frame.input(c.truth);
  if (!c.out.empty()) frame.output(c.out);
}

// Prints the summary, records the main numbers as run-report metrics and writes --out.
void finish(const Common& c, const std::string& kind, const nlohmann::json& result, const std::string& text,
            const std::vector<std::pair<std::string, nlohmann::json>>& metrics) {
  std::cout << text << "\n";
  for (const auto& [name, value] : metrics) pg::RunReport::global().set_metric(name, value);
  if (!c.out.empty()) pg::write_eval_report(c.out, kind, c.estimate, c.truth, result);
}

// A mask's set pixels are its nonzero ones (in any channel); read like every other image, so the same
// formats and size limits apply.
cv::Mat1b read_mask(const std::string& path, const cv::Size& size) {
  const cv::Mat image = pg::read_image(path, pg::ReadMode::gray_float);
  if (image.size() != size)
    throw pg::InputError(path, pg::str("mask is ", image.cols, "x", image.rows, " but the flow is ",
                                       size.width, "x", size.height));
  return image > 0;
}

void check_same_size(const std::string& estimate, const cv::Size& e, const cv::Size& t) {
  if (e != t)
    throw pg::InputError(
        estimate, pg::str("is ", e.width, "x", e.height, " but the truth is ", t.width, "x", t.height));
}

std::string threshold_name(double t) {
  return pg::str(t);
}

}  // namespace

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-eval", "evaluate cameras, depth, meshes or optical flow against ground truth",
       "pg-eval cameras --estimate tracked.json --truth truth.json --out cameras-eval.json\n"
       "pg-eval depth --estimate cam0.exr --truth cam0-truth.exr --align-scale\n"
       "pg-eval mesh --estimate recon.ply --truth truth.ply --thresholds 0.001,0.005\n"
       "pg-eval flow --estimate f.flo --truth gt.flo --occlusions occ.png --invalid inv.png"});
  CLI::App& app = frame.app();
  app.require_subcommand(1);
  app.fallthrough();  // the common flags (--report, --threads, ...) also work after the subcommand

  Common cameras_files;
  std::string alignment = "similarity";
  std::vector<std::string> align_on;
  CLI::App* cameras =
      app.add_subcommand("cameras", "camera centres, rotations and focal lengths (cameras.json)");
  add_common(*cameras, cameras_files, "cameras file");
  cameras->add_option("--align", alignment, "similarity (estimate up to scale) or none (already metric)")
      ->capture_default_str()
      ->check(CLI::IsMember({"similarity", "none"}));
  cameras->add_option("--align-on", align_on, "camera ids to align on, comma separated (default: all)")
      ->delimiter(',');

  Common depth_files;
  pg::DepthEvalOptions depth_options;
  CLI::App* depth =
      app.add_subcommand("depth", "a depth map (EXR) against a true depth map of the same camera");
  add_common(*depth, depth_files, "depth map");
  depth->add_flag("--align-scale", depth_options.align_median_scale,
                  "scale the estimate by median(truth / estimate) first (up-to-scale inputs)");
  depth->add_option("--min-depth", depth_options.min_depth, "ignore truth depths below this")
      ->capture_default_str();
  depth->add_option("--max-depth", depth_options.max_depth, "ignore truth depths above this");
  depth->add_option("--thresholds", depth_options.thresholds, "relative-error thresholds, comma separated")
      ->delimiter(',')
      ->capture_default_str();

  Common mesh_files;
  pg::MeshEvalOptions mesh_options;
  CLI::App* mesh = app.add_subcommand("mesh", "accuracy and completeness of a mesh (PLY or OBJ)");
  add_common(*mesh, mesh_files, "mesh");
  mesh->add_option("--samples", mesh_options.samples,
                   "area-uniform samples per surface, besides the vertices")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t(1), std::size_t(100'000'000)));
  mesh->add_option("--thresholds", mesh_options.thresholds,
                   "distances in scene units for precision / recall / F-score, comma separated")
      ->delimiter(',');

  Common flow_files;
  std::string occlusions_path, invalid_path;
  CLI::App* flow = app.add_subcommand("flow", "optical flow (Middlebury .flo) against true flow");
  add_common(*flow, flow_files, "flow (.flo)");
  flow->add_option("--occlusions", occlusions_path,
                   "mask image, nonzero = occluded (MPI-Sintel occlusions/)");
  flow->add_option("--invalid", invalid_path, "mask image, nonzero = not evaluated (MPI-Sintel invalid/)");

  return frame.run(argc, argv, [&] {
    if (cameras->parsed()) {
      declare_files(frame, cameras_files);
      pg::CameraEvalOptions options;
      options.alignment = pg::camera_alignment_from_string(alignment);
      options.align_on = align_on;
      pg::CameraEvalResult r = pg::evaluate_cameras(pg::read_cameras(cameras_files.estimate),
                                                    pg::read_cameras(cameras_files.truth), options);
      finish(cameras_files, "cameras", r.to_json(), r.to_text(),
             {{"cameras_matched", r.cameras.size()},
              {"alignment_scale", r.alignment.scale},
              {"centre_error_mean", r.centre_error.mean},
              {"centre_error_median", r.centre_error.median},
              {"centre_error_max", r.centre_error.max},
              {"centre_error_rms", r.centre_error.rms},
              {"rotation_error_deg_mean", r.rotation_error_deg.mean},
              {"rotation_error_deg_median", r.rotation_error_deg.median},
              {"rotation_error_deg_max", r.rotation_error_deg.max},
              {"orientation_error_deg_median", r.orientation_error_deg.median},
              {"orientation_error_deg_max", r.orientation_error_deg.max}});
    } else if (depth->parsed()) {
      declare_files(frame, depth_files);
      pg::DepthMap estimate = pg::read_depth_exr(depth_files.estimate);
      pg::DepthMap truth = pg::read_depth_exr(depth_files.truth);
      check_same_size(depth_files.estimate, estimate.depth.size(), truth.depth.size());
      if (estimate.kind != truth.kind)
        throw pg::InputError(depth_files.estimate, "depth kind " + pg::to_string(estimate.kind) +
                                                       " differs from the truth's " +
                                                       pg::to_string(truth.kind));
      pg::DepthEvalResult r = pg::evaluate_depth(estimate, truth, depth_options);
      std::vector<std::pair<std::string, nlohmann::json>> metrics = {
          {"coverage", r.coverage},
          {"scale", r.scale},
          {"relative_error_mean", r.relative_error.mean},
          {"relative_error_median", r.relative_error.median},
          {"relative_error_p95", r.relative_error.p95},
          {"rmse", r.rmse}};
      for (std::size_t i = 0; i < r.thresholds.size(); ++i)
        metrics.emplace_back("fraction_below_" + threshold_name(r.thresholds[i]), r.fraction_below[i]);
      finish(depth_files, "depth", r.to_json(), r.to_text(), metrics);
    } else if (mesh->parsed()) {
      declare_files(frame, mesh_files);
      mesh_options.seed = frame.seed();
      pg::MeshEvalResult r = pg::evaluate_mesh(pg::read_mesh(mesh_files.estimate),
                                               pg::read_mesh(mesh_files.truth), mesh_options);
      std::vector<std::pair<std::string, nlohmann::json>> metrics = {
          {"accuracy_mean", r.accuracy.mean},
          {"accuracy_median", r.accuracy.median},
          {"accuracy_p95", r.accuracy.p95},
          {"completeness_mean", r.completeness.mean},
          {"completeness_median", r.completeness.median},
          {"completeness_p95", r.completeness.p95},
          {"chamfer", r.chamfer}};
      for (std::size_t i = 0; i < r.thresholds.size(); ++i)
        metrics.emplace_back("fscore_" + threshold_name(r.thresholds[i]), r.fscore[i]);
      finish(mesh_files, "mesh", r.to_json(), r.to_text(), metrics);
    } else if (flow->parsed()) {
      declare_files(frame, flow_files);
      if (!occlusions_path.empty()) frame.input(occlusions_path);
      if (!invalid_path.empty()) frame.input(invalid_path);
      cv::Mat2f estimate = pg::read_flo(flow_files.estimate);
      cv::Mat2f truth = pg::read_flo(flow_files.truth);
      check_same_size(flow_files.estimate, estimate.size(), truth.size());
      cv::Mat1b occlusions, invalid;
      if (!occlusions_path.empty()) occlusions = read_mask(occlusions_path, truth.size());
      if (!invalid_path.empty()) invalid = read_mask(invalid_path, truth.size());
      pg::FlowEvalResult r = pg::evaluate_flow(estimate, truth, occlusions.empty() ? nullptr : &occlusions,
                                               invalid.empty() ? nullptr : &invalid);
      finish(flow_files, "flow", r.to_json(), r.to_text(),
             {{"coverage", r.coverage},
              {"epe_all", r.epe_all},
              {"epe_non_occluded", pg::json_number(r.epe_non_occluded)},
              {"epe_occluded", pg::json_number(r.epe_occluded)},
              {"bad_1", r.bad_1},
              {"bad_3", r.bad_3},
              {"bad_5", r.bad_5},
              {"angular_error_deg", r.angular_error_deg}});
    }
  });
}
