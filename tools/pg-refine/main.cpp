// pg-refine: makes a mesh agree with the photographs, under the user's direction (working set, pins,
// the details brush). Subcommands: run (the default: refinement iterations), paint, rebase.
#include <algorithm>
#include <cstring>
#include <iterator>
#include <map>
#include <set>

#include "common/cli.h"
#include "pg/camera/cameras_io.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"
#include "pg/flow/flow_memory.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/vertex_mask.h"
#include "pg/refine/brush.h"
#include "pg/refine/brush_strokes.h"
#include "pg/refine/photometric.h"
#include "pg/refine/refine.h"
#include "pg/refine/refine_caches.h"
#include "pg/refine/refine_memory.h"

namespace fs = std::filesystem;

namespace {

struct RunArgs {
  std::string mesh, cameras, out;
  std::vector<std::string> views, pairs;
  int pairs_per_view = 2;
  std::string working_set, pinned, pre_cache, post_cache, error_images;
  std::string flow_mode = "epipolar", flow_preset = "fast";
  pg::RefineOptions options;
};

struct PaintArgs {
  std::string mesh, pre, post, out, weights, strokes, cameras, mode = "paint", working_set, pinned;
};

struct RebaseArgs {
  std::string mesh, out, post;
};

// A mask read from its file and checked against the mesh (empty path: no mask).
std::vector<float> read_mask(pg::cli::Frame& frame, const std::string& path, const pg::Mesh& mesh) {
  if (path.empty()) return {};
  frame.input(path);
  const pg::VertexMask mask = pg::read_vertex_mask(path);
  pg::check_fits(mask, mesh, path);
  return mask.weights;
}

const pg::Camera& find_camera(const pg::CameraSet& set, const std::string& id,
                              const std::string& cameras_file) {
  const pg::Camera* camera = set.find(id);
  if (!camera) throw pg::InputError(cameras_file, "has no camera '" + id + "'");
  return *camera;
}

fs::path image_path(const pg::Camera& camera, const std::string& cameras_file) {
  if (camera.image.empty()) throw pg::InputError(cameras_file, "camera '" + camera.id + "' names no image");
  const fs::path image(camera.image);
  return image.is_absolute() ? image : fs::path(cameras_file).parent_path() / image;
}

// --max-memory: the refinement's estimate (from the mesh and the cameras of the views in use, before
// any photograph is decoded) must fit, so a job that cannot finish fails with exit code 5 up front.
void require_memory(const pg::Mesh& mesh, const std::vector<pg::Camera>& cameras, const std::set<int>& used,
                    const RunArgs& args) {
  std::vector<pg::Camera> views;
  std::uint64_t image_bytes_per_pixel = 0;
  for (int v : used) {
    views.push_back(cameras[v]);
    image_bytes_per_pixel = std::max(image_bytes_per_pixel,
                                     pg::decoded_image_bytes_per_pixel(image_path(cameras[v], args.cameras)));
  }
  pg::cli::require_memory(pg::refine_memory_bytes(mesh, views, image_bytes_per_pixel, args.options),
                          pg::str("refinement of ", mesh.vertex_count(), " vertices and ", mesh.faces.size(),
                                  " faces against ", views.size(), " views"));
}

void run_refinement(pg::cli::Frame& frame, RunArgs& args) {
  frame.input(args.mesh);
  frame.input(args.cameras);
  frame.output(args.out);
  if (!args.pre_cache.empty()) frame.output(args.pre_cache);
  if (!args.post_cache.empty()) frame.output(args.post_cache);
  if (!args.error_images.empty()) frame.output_dir(args.error_images);
  args.options.flow_mode = args.flow_mode == "free" ? pg::RefineFlow::free : pg::RefineFlow::epipolar;
  args.options.flow = pg::refine_flow_options(args.flow_preset);
  args.options.check();

  const pg::Mesh mesh = pg::read_mesh(args.mesh);
  const pg::CameraSet set = pg::read_cameras(args.cameras);
  pg::RefineMasks masks{read_mask(frame, args.working_set, mesh), read_mask(frame, args.pinned, mesh)};

  // The views: those named, or every camera with an image (cameras.md allows none); each must see
  // the mesh.
  std::vector<pg::Camera> cameras;
  if (args.views.empty())
    std::copy_if(set.cameras.begin(), set.cameras.end(), std::back_inserter(cameras),
                 [](const pg::Camera& c) { return !c.image.empty(); });
  else
    for (const auto& id : args.views) cameras.push_back(find_camera(set, id, args.cameras));
  std::map<std::string, int> index;
  for (std::size_t i = 0; i < cameras.size(); ++i) index[cameras[i].id] = int(i);
  std::vector<pg::ViewPair> pairs;
  for (const auto& text : args.pairs) {
    const auto colon = text.find(':');
    if (colon == std::string::npos) throw pg::UsageError("--pairs: '" + text + "' is not A:B");
    const std::string a = text.substr(0, colon), b = text.substr(colon + 1);
    for (const auto& id : {a, b}) {
      if (find_camera(set, id, args.cameras).image.empty())
        throw pg::InputError(args.cameras, "camera '" + id + "' names no image");
      if (!index.count(id)) throw pg::UsageError("--pairs: view '" + id + "' is not among --views");
    }
    pairs.push_back({index[a], index[b]});
  }
  if (pairs.empty()) pairs = pg::select_view_pairs(mesh, cameras, args.pairs_per_view);
  if (pairs.empty())
    throw pg::FailedError("no pair of views overlaps on the mesh with a useful baseline (use --pairs)");

  std::set<int> used;
  for (const auto& p : pairs) used.insert({p.a, p.b});
  require_memory(mesh, cameras, used, args);
  std::vector<pg::RefineView> views(cameras.size());
  for (int v : used) {
    const pg::Camera& camera = cameras[v];
    if (!pg::camera_sees_mesh(mesh, camera))
      throw pg::InputError(args.cameras,
                           "camera '" + camera.id +
                               "' does not see the mesh: it is behind the camera or outside its "
                               "image (wrong cameras for this mesh, or another coordinate frame?)");
    const fs::path path = image_path(camera, args.cameras);
    frame.input(path);
    views[v] = {camera, pg::read_image(path)};
    if (views[v].image.cols != camera.width || views[v].image.rows != camera.height)
      throw pg::InputError(
          path, pg::str("is ", views[v].image.cols, "x", views[v].image.rows, " but camera '", camera.id,
                        "' is ", camera.width, "x", camera.height));
  }
  for (const auto& p : pairs) pg::log::info("pair ", cameras[p.a].id, " <-> ", cameras[p.b].id);

  const pg::RefineResult result = pg::refine_mesh(mesh, views, pairs, masks, args.options);

  pg::Mesh refined = result.mesh;
  refined.provenance = pg::Provenance::current();
  pg::write_mesh(args.out, refined);
  if (!args.pre_cache.empty()) pg::write_refine_cache(args.pre_cache, mesh);
  if (!args.post_cache.empty()) pg::write_refine_cache(args.post_cache, refined);
  if (!args.error_images.empty()) {
    const fs::path before = fs::path(args.error_images) / "error_before.png";
    const fs::path after = fs::path(args.error_images) / "error_after.png";
    frame.output(before);
    frame.output(after);
    pg::write_image(before, pg::error_visualisation(result.error_before));
    pg::write_image(after, pg::error_visualisation(result.error_after));
  }

  // The run report: per iteration, the mean displacement and each directed pair's error.
  auto& report = pg::RunReport::global();
  nlohmann::json iterations = nlohmann::json::array();
  double render = 0, flow = 0, displacement = 0;
  auto pair_json = [&](const pg::PairError& e) {
    return nlohmann::json{{"a", cameras[e.a].id},
                          {"b", cameras[e.b].id},
                          {"ncc_error", e.ncc_error},
                          {"mean_abs_error", e.mean_abs_error},
                          {"pixels", e.pixels}};
  };
  for (const auto& it : result.iterations) {
    nlohmann::json before = nlohmann::json::array(), after = nlohmann::json::array();
    for (const auto& e : it.before) before.push_back(pair_json(e));
    for (const auto& e : it.after) after.push_back(pair_json(e));
    iterations.push_back({{"iteration", it.iteration + 1},
                          {"mean_displacement", it.mean_displacement},
                          {"max_displacement", it.max_displacement},
                          {"moved_vertices", it.moved_vertices},
                          {"error_before", before},
                          {"error_after", after}});
    render += it.render_seconds;
    flow += it.flow_seconds;
    displacement += it.displacement_seconds;
  }
  nlohmann::json pair_ids = nlohmann::json::array();
  for (const auto& p : pairs) pair_ids.push_back({cameras[p.a].id, cameras[p.b].id});
  report.set_metric("pairs", pair_ids);
  report.set_metric("flow_mode", args.flow_mode);
  report.set_metric("iterations", iterations);
  auto mean_ncc = [](const std::vector<pg::PairError>& errors) {
    double sum = 0;
    for (const auto& e : errors) sum += e.ncc_error;
    return errors.empty() ? 0.0 : sum / double(errors.size());
  };
  const double first = mean_ncc(result.iterations.front().before),
               last = mean_ncc(result.iterations.back().after);
  report.set_metric("ncc_error_before", first);
  report.set_metric("ncc_error_after", last);
  report.add_timing("render", render);
  report.add_timing("flow", flow);
  report.add_timing("displacement", displacement);
  pg::log::info("photometric error (1 - NCC, mean over pairs): ", first, " -> ", last);
}

void run_paint(pg::cli::Frame& frame, const PaintArgs& args) {
  frame.input(args.mesh);
  frame.input(args.pre);
  frame.input(args.post);
  frame.output(args.out);
  if (args.weights.empty() == args.strokes.empty())
    throw pg::UsageError("paint: give exactly one of --weights or --strokes");
  pg::Mesh current = pg::read_mesh(args.mesh);
  const std::vector<Eigen::Vector3f> unpainted = current.positions;
  const pg::Mesh pre = pg::read_refine_cache(args.pre, current);
  const pg::Mesh post = pg::read_refine_cache(args.post, current);
  const pg::BrushLimits limits{read_mask(frame, args.working_set, current),
                               read_mask(frame, args.pinned, current)};

  if (!args.weights.empty()) {
    const std::vector<float> weights = read_mask(frame, args.weights, current);
    const auto mode = pg::brush_mode_from_string(args.mode);
    pg::blend_towards(current.positions, mode == pg::BrushMode::paint ? post.positions : pre.positions,
                      weights, limits);
  } else {
    frame.input(args.strokes);
    const pg::BrushStrokes strokes = pg::read_brush_strokes(args.strokes);
    std::optional<pg::CameraSet> cameras;
    for (std::size_t i = 0; i < strokes.strokes.size(); ++i) {
      const pg::BrushStroke& stroke = strokes.strokes[i];
      const pg::Camera* camera = nullptr;
      if (stroke.screen) {
        if (args.cameras.empty())
          throw pg::InputError(args.strokes, pg::str("strokes[", i, "] is a screen stroke: give --cameras"));
        if (!cameras) {
          frame.input(args.cameras);
          cameras = pg::read_cameras(args.cameras);
        }
        camera = &find_camera(*cameras, stroke.view, args.cameras);
      }
      const std::vector<float> weights = pg::stroke_weights(current, stroke, camera);
      pg::blend_towards(current.positions,
                        stroke.mode == pg::BrushMode::paint ? post.positions : pre.positions, weights,
                        limits);
    }
    pg::RunReport::global().set_metric("strokes", strokes.strokes.size());
  }
  current.update_moved_normals(unpainted);
  current.provenance = pg::Provenance::current();
  pg::write_mesh(args.out, current);
}

void run_rebase(pg::cli::Frame& frame, const RebaseArgs& args) {
  frame.input(args.mesh);
  frame.output(args.out);
  const pg::Mesh current = pg::read_mesh(args.mesh);
  if (!args.post.empty()) {
    frame.input(args.post);
    pg::read_refine_cache(args.post, current);
  }
  pg::write_refine_cache(args.out, current);
}

}  // namespace

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-refine", "make a mesh agree with the photographs: refinement iterations and the details brush",
       "  pg-refine --mesh merged.ply --cameras cameras.json --out refined.ply --pre-cache pre.ply \\\n"
       "            --post-cache post.ply --working-set face.pgmask.json --pinned rim.pgmask.json\n"
       "  pg-refine paint --mesh refined.ply --pre pre.ply --post post.ply --strokes strokes.json "
       "--cameras cameras.json --out touched.ply\n"
       "  pg-refine paint --mode erase --mesh touched.ply --pre pre.ply --post post.ply --weights "
       "w.pgmask.json "
       "--out undone.ply\n"
       "  pg-refine rebase --mesh touched.ply --out pre2.ply\n"
       "  pg-refine --mesh m.ply --cameras c.json --out r.ply --max-memory 8G\n"
       "            # exit 5 before reading any image if the estimate needs more"});
  CLI::App& app = frame.app();
  app.require_subcommand(1);
  app.fallthrough();

  RunArgs run_args;
  CLI::App* run = app.add_subcommand("run", "refinement iterations (the default subcommand)");
  run->add_option("--mesh", run_args.mesh, "the mesh to refine (PLY/OBJ; left untouched)")->required();
  run->add_option("--cameras", run_args.cameras, "cameras file; images are found through it")->required();
  run->add_option("--out", run_args.out, "the refined mesh (same topology, 'displacement' property)")
      ->required();
  run->add_option("--views", run_args.views, "camera ids to use, comma separated (default: all)")
      ->delimiter(',');
  run->add_option("--pairs", run_args.pairs,
                  "view pairs A:B, comma separated (default: chosen automatically)")
      ->delimiter(',');
  run->add_option("--pairs-per-view", run_args.pairs_per_view, "automatic pairs: partners per view")
      ->capture_default_str()
      ->check(CLI::Range(1, 10));
  run->add_option("--iterations", run_args.options.iterations, "refinement iterations")
      ->capture_default_str();
  run->add_option("--scale", run_args.options.scale, "image resolution used, relative to the cameras")
      ->capture_default_str();
  run->add_option("--step", run_args.options.step, "fraction of each estimated displacement applied")
      ->capture_default_str();
  run->add_option("--smoothness", run_args.options.smoothness, "smoothness of the displacement field")
      ->capture_default_str();
  run->add_option("--smoothing-iterations", run_args.options.smoothing_iterations,
                  "smoothing sweeps (also how many rings unobserved vertices are filled in)")
      ->capture_default_str();
  run->add_option("--mesh-accuracy", run_args.options.mesh_accuracy,
                  "expected error of the input mesh (scene units; 0 = unknown): each pixel then counts by "
                  "how precisely its pair resolves depth against it, so an accurate mesh is not made worse")
      ->capture_default_str();
  run->add_option("--flow-precision", run_args.options.flow_precision_px,
                  "with --mesh-accuracy: the flow's standard error in working-scale pixels")
      ->capture_default_str();
  run->add_flag("--normal-only", run_args.options.normal_only, "move vertices only along their normals");
  run->add_option("--tolerance", run_args.options.tolerance,
                  "stop when the mean displacement falls below this (scene units; 0 = run all iterations)")
      ->capture_default_str();
  run->add_option("--max-displacement", run_args.options.max_displacement,
                  "per-pixel displacement outlier limit (scene units; 0 = 5% of the mesh's size)")
      ->capture_default_str();
  run->add_option("--border-taper", run_args.options.border_taper_px,
                  "pixels over which weights ramp up from the border of the co-visible region and of the "
                  "image (a panorama's columns wrap)")
      ->capture_default_str();
  run->add_option("--working-set-taper", run_args.options.working_set_taper_rings,
                  "vertex rings over which motion ramps up inside the working set")
      ->capture_default_str();
  run->add_option("--flow", run_args.flow_mode,
                  "epipolar (1-D, along the lines through the current surface; exact cameras) or free (2-D)")
      ->capture_default_str()
      ->check(CLI::IsMember({"epipolar", "free"}));
  run->add_option("--flow-preset", run_args.flow_preset, "fast, balanced or accurate")
      ->capture_default_str()
      ->check(CLI::IsMember({"fast", "balanced", "accurate"}));
  run->add_option("--working-set", run_args.working_set, "vertex mask: only these vertices move");
  run->add_option("--pinned", run_args.pinned, "vertex mask: these vertices never move");
  run->add_option("--pre-cache", run_args.pre_cache, "write the pre-iteration state here (for the brush)");
  run->add_option("--post-cache", run_args.post_cache, "write the post-iteration state here (for the brush)");
  run->add_option("--error-images", run_args.error_images,
                  "folder for error_before.png / error_after.png of the first pair");

  PaintArgs paint_args;
  CLI::App* paint =
      app.add_subcommand("paint", "blend the mesh towards the post cache (paint) or the pre cache (erase)");
  paint->add_option("--mesh", paint_args.mesh, "the current mesh")->required();
  paint->add_option("--pre", paint_args.pre, "the pre-iteration cache")->required();
  paint->add_option("--post", paint_args.post, "the post-iteration cache")->required();
  paint->add_option("--out", paint_args.out, "the painted mesh")->required();
  paint->add_option("--weights", paint_args.weights, "vertex mask of brush weights (painted)");
  paint->add_option("--mode", paint_args.mode, "with --weights: paint or erase")
      ->capture_default_str()
      ->check(CLI::IsMember({"paint", "erase"}));
  paint->add_option("--strokes", paint_args.strokes, "brush strokes file (formats/brush-strokes.md)");
  paint->add_option("--cameras", paint_args.cameras, "cameras file, for screen-space strokes");
  paint->add_option("--working-set", paint_args.working_set, "vertex mask: only these vertices change");
  paint->add_option("--pinned", paint_args.pinned, "vertex mask: these vertices never change");

  RebaseArgs rebase_args;
  CLI::App* rebase = app.add_subcommand("rebase", "make the current mesh the new pre-iteration cache");
  rebase->add_option("--mesh", rebase_args.mesh, "the current mesh")->required();
  rebase->add_option("--out", rebase_args.out, "the new pre-iteration cache")->required();
  rebase->add_option("--post", rebase_args.post, "the post cache it goes with (checks the topology)");

  // `run` is the default subcommand: pg-refine --mesh ... means pg-refine run --mesh ...
  std::vector<char*> arguments(argv, argv + argc);
  static char run_name[] = "run";
  // A subcommand may follow the common flags (`pg-refine --threads 2 rebase ...`): the first
  // argument that is not one of the frame's own options (or its value) says whether one is named.
  const auto names_subcommand = [&] {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const std::size_t equals = a.find('=');
      if (const CLI::Option* common =
              a.starts_with("--") ? app.get_option_no_throw(a.substr(0, equals)) : nullptr) {
        if (common->get_type_size() != 0 && equals == std::string::npos) ++i;  // its value follows
        continue;
      }
      return a == "run" || a == "paint" || a == "rebase";
    }
    return false;
  }();
  const bool asks_top_level = argc > 1 && (!std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
                                           !std::strcmp(argv[1], "--version"));
  if (argc > 1 && !names_subcommand && !asks_top_level) arguments.insert(arguments.begin() + 1, run_name);

  return frame.run(int(arguments.size()), arguments.data(), [&] {
    if (run->parsed())
      run_refinement(frame, run_args);
    else if (paint->parsed())
      run_paint(frame, paint_args);
    else if (rebase->parsed())
      run_rebase(frame, rebase_args);
  });
}
