// pg-calib: checkerboard calibration (calibrate) and undistortion to a pinhole camera (flatten).
#include <glob.h>
#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "common/cli.h"
#include "pg/calib/calibrate.h"
#include "pg/calib/detect.h"
#include "pg/calib/flatten.h"
#include "pg/calib/report.h"
#include "pg/calib/stereo.h"
#include "pg/camera/camera_json.h"
#include "pg/camera/cameras_io.h"
#include "pg/camera/size_check.h"
#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"
#include "pg/image/image_io.h"

namespace fs = std::filesystem;
using namespace pg;
using namespace pg::calib;

namespace {

const std::set<std::string> image_extensions = {".jpg",  ".jpeg", ".png", ".tif",
                                                ".tiff", ".exr",  ".hdr", ".bmp"};

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return image_extensions.count(ext) > 0;
}

// Each argument is a file, a folder (its images, sorted) or a glob pattern (quoted in the shell).
std::vector<fs::path> expand_images(const std::vector<std::string>& args) {
  std::vector<fs::path> files;
  for (const std::string& arg : args) {
    if (fs::is_directory(arg)) {
      std::vector<fs::path> found;
      for (const auto& e : fs::directory_iterator(arg))
        if (e.is_regular_file() && is_image(e.path())) found.push_back(e.path());
      if (found.empty()) throw InputError(arg, "folder holds no images (jpg, png, tif, exr, hdr, bmp)");
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else if (arg.find_first_of("*?[") != std::string::npos) {
      glob_t g{};
      const int rc = ::glob(arg.c_str(), 0, nullptr, &g);
      std::vector<fs::path> found;
      if (rc == 0)
        for (std::size_t i = 0; i < g.gl_pathc; ++i) found.emplace_back(g.gl_pathv[i]);
      ::globfree(&g);
      if (found.empty()) throw InputError(arg, "pattern matches no files");
      files.insert(files.end(), found.begin(), found.end());  // glob sorts
    } else {
      files.emplace_back(arg);
    }
  }
  if (files.empty()) throw UsageError("no images given");
  return files;
}

struct CameraRun {
  std::vector<ImageDetection> detections;
  std::vector<ViewInput> views;  // found views, in image order
  CalibrationResult result;
};

// Throws unless `image` (of `size`) is the size of `first`, the first image of a calibration.
void require_first_size(const fs::path& image, cv::Size size, const fs::path& first, cv::Size first_size) {
  if (size != first_size)
    throw InputError(
        image, str("is ", size.width, "x", size.height, " but ", first.string(), " is ", first_size.width,
                   "x", first_size.height, "; calibrate one image size at a time"));
}

// Every image's size from its header, before any board is searched for, so that a wrong image fails
// in seconds. Formats without a header pg can peek are checked when decoded.
void check_one_size(const std::vector<fs::path>& files) {
  std::optional<std::pair<fs::path, cv::Size>> first;  // the first image whose size was read
  for (const fs::path& f : files) {
    const std::optional<cv::Size> size = peek_image_size(f);
    if (!size) continue;
    if (!first) first.emplace(f, *size);
    require_first_size(f, *size, first->first, first->second);
  }
}

// Detects the board in every image (all the same size) and calibrates.
CameraRun calibrate_images(const std::vector<fs::path>& files, const BoardSpec& board, Detector detector,
                           const CalibrationOptions& options, const std::string& id) {
  CameraRun run;
  std::optional<cv::Size> size;
  for (const fs::path& f : files) {
    const cv::Mat image = read_image(f);
    if (!size) size = image.size();
    require_first_size(f, image.size(), files.front(), *size);
    ImageDetection d{f.filename().string(), detect_board(image, board, detector)};
    if (d.detection.found)
      run.views.push_back({d.image, d.detection.corners});
    else
      log::warn(f.string(), ": ", d.detection.problem);
    run.detections.push_back(std::move(d));
  }
  log::info(id, ": board found in ", run.views.size(), " of ", files.size(), " images");
  if (run.views.empty())
    throw FailedError(str("no ", board.cols, "x", board.rows, " board found in any of the ", files.size(),
                          " images (check --board: inner corners, not squares)"));
  run.result = calibrate(run.views, board, *size, options);
  run.result.camera.id = id;
  const CalibrationResult& r = run.result;
  log::info(id, ": RMS ", r.rms, " px per corner (OpenCV ", r.opencv_rms, " px), ", r.views_used, " views, ",
            r.corners_dropped, " corners rejected; fx ", r.camera.intrinsics.fx, " fy ",
            r.camera.intrinsics.fy, " cx ", r.camera.intrinsics.cx, " cy ", r.camera.intrinsics.cy);
  return run;
}

void add_metrics(const std::string& prefix, const CalibrationResult& r) {
  RunReport& report = RunReport::global();
  report.set_metric(prefix + "rms_px", r.rms);
  report.set_metric(prefix + "opencv_rms_px", r.opencv_rms);
  report.set_metric(prefix + "views_used", r.views_used);
  report.set_metric(prefix + "corners_dropped", r.corners_dropped);
  report.set_metric(prefix + "fx", r.camera.intrinsics.fx);
  report.set_metric(prefix + "fy", r.camera.intrinsics.fy);
  for (const ProjectionUncertainty& u : r.uncertainty)
    report.set_metric(prefix + "uncertainty_px_" + u.where, u.stddev_px);
}

fs::path with_suffix(const fs::path& report, const std::string& suffix) {
  fs::path p = report;
  return p.replace_extension(suffix);
}

void run_calibrate(cli::Frame& frame, const std::vector<std::string>& images,
                   const std::vector<std::string>& stereo_images, const std::string& board_text,
                   double square, const std::string& detector_name, const std::string& model_name,
                   CalibrationOptions options, const std::string& out, std::string report_path,
                   const std::string& id, const std::string& stereo_id) {
  const BoardSpec board = parse_board(board_text, square);
  const Detector detector = detector_from_string(detector_name);
  options.model = lens_model_from_string(model_name);
  if (options.model == LensModel::fisheye && options.zero_tangential)
    log::info("--zero-tangential has no effect on the fisheye model");
  if (id == stereo_id) throw UsageError("--id and --stereo-id must differ");
  if (report_path.empty()) report_path = with_suffix(out, ".calibration.json").string();
  const fs::path coverage_png = with_suffix(report_path, ".coverage.png");
  const fs::path distortion_png = with_suffix(report_path, ".distortion.png");
  const std::vector<fs::path> files = expand_images(images);
  const std::vector<fs::path> second_files =
      stereo_images.empty() ? std::vector<fs::path>{} : expand_images(stereo_images);
  if (!second_files.empty() && second_files.size() != files.size())
    throw UsageError(str("--stereo-images lists ", second_files.size(), " images, --images ", files.size(),
                         "; they are paired in sorted order"));
  for (const auto& f : files) frame.input(f);
  for (const auto& f : second_files) frame.input(f);
  check_one_size(files);
  check_one_size(second_files);
  for (const fs::path& o : {fs::path(out), fs::path(report_path), coverage_png, distortion_png})
    frame.output(o);
  std::vector<fs::path> second_pngs;
  if (!second_files.empty()) {
    second_pngs = {with_suffix(report_path, "." + stereo_id + ".coverage.png"),
                   with_suffix(report_path, "." + stereo_id + ".distortion.png")};
    for (const auto& p : second_pngs) frame.output(p);
  }

  // Everything is computed before anything is written: a failure leaves no partial output.
  CameraRun first = calibrate_images(files, board, detector, options, id);
  add_metrics("", first.result);
  CameraSet set;
  set.cameras.push_back(first.result.camera);
  std::vector<nlohmann::ordered_json> calibrations = {
      camera_calibration_json(first.result, first.detections)};
  std::optional<StereoResult> stereo;
  std::optional<CameraRun> second;
  if (!second_files.empty()) {
    second = calibrate_images(second_files, board, detector, options, stereo_id);
    add_metrics(stereo_id + "_", second->result);
    // Pairs: images at the same position in both sorted lists, used in both calibrations.
    std::map<std::string, const ViewInput*> first_used, second_used;
    for (std::size_t i = 0; i < first.views.size(); ++i)
      if (first.result.views[i].used) first_used[first.views[i].name] = &first.views[i];
    for (std::size_t i = 0; i < second->views.size(); ++i)
      if (second->result.views[i].used) second_used[second->views[i].name] = &second->views[i];
    std::vector<ViewInput> a, b;
    for (std::size_t i = 0; i < files.size(); ++i) {
      const auto fa = first_used.find(files[i].filename().string());
      const auto fb = second_used.find(second_files[i].filename().string());
      if (fa != first_used.end() && fb != second_used.end()) {
        a.push_back(*fa->second);
        b.push_back(*fb->second);
      }
    }
    stereo = stereo_calibrate(a, b, board, first.result.camera, second->result.camera);
    log::info("stereo: baseline ", stereo->baseline, " m from ", stereo->pairs, " pairs, RMS ", stereo->rms,
              " px");
    RunReport::global().set_metric("stereo_baseline_m", stereo->baseline);
    RunReport::global().set_metric("stereo_rms_px", stereo->rms);
    Camera right = second->result.camera;
    right.cam_from_world = stereo->second_from_first;
    right.rig = "stereo";
    set.cameras.front().rig = "stereo";
    set.cameras.push_back(right);
    set.rigs.push_back({"stereo", {id, stereo_id}, std::nullopt});
    calibrations.push_back(camera_calibration_json(second->result, second->detections));
  }

  write_cameras(out, set);
  nlohmann::ordered_json report = calibration_report_json(board, options, calibrations, stereo);
  report["pictures"] = {coverage_png.filename().string(), distortion_png.filename().string()};
  if (second)
    report["pictures"].insert(report["pictures"].end(),
                              {second_pngs[0].filename().string(), second_pngs[1].filename().string()});
  write_file_atomically(report_path, report.dump(2) + "\n");  // ordered: format, version, provenance first
  write_image(coverage_png, draw_coverage(first.result, first.views, board));
  write_image(distortion_png, draw_distortion(first.result.camera));
  if (second) {
    write_image(second_pngs[0], draw_coverage(second->result, second->views, board));
    write_image(second_pngs[1], draw_distortion(second->result.camera));
  }
}

void run_flatten(cli::Frame& frame, const std::string& cameras_path, const std::string& camera_id,
                 const std::vector<std::string>& images, const std::string& out, double alpha) {
  if (!(alpha >= 0 && alpha <= 1)) throw UsageError(str("--alpha ", alpha, " must be in [0, 1]"));
  frame.input(cameras_path);
  const CameraSet source = read_cameras(cameras_path);
  const fs::path source_dir = fs::path(cameras_path).parent_path();
  // Jobs: (camera, image path) pairs. With --images one camera serves every image; otherwise each
  // camera flattens its own image.
  struct Job {
    Camera camera;
    fs::path image;
  };
  std::vector<Job> jobs;
  if (!images.empty()) {
    const Camera* camera = nullptr;
    if (!camera_id.empty()) {
      camera = source.find(camera_id);
      if (!camera) throw InputError(cameras_path, "no camera with id \"" + camera_id + "\"");
    } else if (source.cameras.size() == 1) {
      camera = &source.cameras.front();
    } else {
      throw UsageError(
          str(cameras_path, " holds ", source.cameras.size(), " cameras; choose one with --camera-id"));
    }
    for (const fs::path& f : expand_images(images)) {
      Job job{*camera, f};
      job.camera.id = f.stem().string();
      job.camera.image = f.filename().string();
      jobs.push_back(job);
    }
  } else {
    for (const Camera& c : source.cameras) {
      if (!camera_id.empty() && c.id != camera_id) continue;
      if (c.image.empty())
        throw InputError(cameras_path, "camera \"" + c.id + "\" names no image; pass --images");
      const fs::path image = fs::path(c.image).is_absolute() ? fs::path(c.image) : source_dir / c.image;
      jobs.push_back({c, image});
    }
    if (jobs.empty()) throw InputError(cameras_path, "no camera to flatten");
  }
  frame.output_dir(out);
  std::set<std::string> names;
  for (Job& job : jobs) {
    frame.input(job.image);
    const std::string name = job.image.filename().string();
    if (!names.insert(name).second)
      throw UsageError("two images are both named " + name + "; flatten them separately");
    frame.output(fs::path(out) / name);
    // Every image's size from its header before the first is flattened (formats without a header pg
    // can peek are checked when decoded).
    if (const std::optional<cv::Size> size = peek_image_size(job.image))
      require_camera_size(job.image, size->width, size->height, job.camera);
  }
  const fs::path cameras_out = fs::path(out) / "cameras.json";
  frame.output(cameras_out);

  CameraSet flattened;
  std::map<std::string, FlattenMaps> cache;  // maps by camera parameters' identity (same camera, same maps)
  double valid = 1;
  for (const Job& job : jobs) {
    const cv::Mat image = read_image(job.image);
    require_camera_size(job.image, image.cols, image.rows, job.camera);
    const std::string key = nlohmann::json(camera_to_json([&] {
                              Camera c = job.camera;
                              c.id.clear();
                              c.image.clear();
                              c.cam_from_world = {};
                              c.rig.reset();
                              c.quality.reset();
                              return c;
                            }()))
                                .dump();
    auto it = cache.find(key);
    if (it == cache.end()) it = cache.emplace(key, flatten_maps(job.camera, alpha)).first;
    const FlattenMaps& maps = it->second;
    valid = std::min(valid, maps.valid_fraction);
    const fs::path target = fs::path(out) / job.image.filename();
    write_image(target, flatten_image(image, maps));
    Camera c = maps.pinhole;
    c.id = job.camera.id;
    c.image = job.image.filename().string();
    c.cam_from_world = job.camera.cam_from_world;
    c.rig = job.camera.rig;
    c.quality = job.camera.quality;
    flattened.cameras.push_back(c);
  }
  // A rig stays when every camera it names was flattened (each camera its own image); a camera whose
  // rig did not stay, or that flattened --images under another id, leaves it.
  for (const Rig& rig : source.rigs)
    if (images.empty() && std::all_of(rig.camera_ids.begin(), rig.camera_ids.end(),
                                      [&](const std::string& id) { return flattened.find(id) != nullptr; }))
      flattened.rigs.push_back(rig);
  for (Camera& c : flattened.cameras)
    if (c.rig && std::none_of(flattened.rigs.begin(), flattened.rigs.end(),
                              [&](const Rig& rig) { return rig.id == *c.rig; }))
      c.rig.reset();
  write_cameras(cameras_out, flattened);
  const Intrinsics& k = flattened.cameras.front().intrinsics;
  log::info("flattened ", jobs.size(), " images, alpha ", alpha, ": f ", k.fx, " cx ", k.cx, " cy ", k.cy,
            "; smallest valid fraction ", valid);
  RunReport::global().set_metric("images", int(jobs.size()));
  RunReport::global().set_metric("valid_fraction_min", valid);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Frame frame(
      {"pg-calib", "checkerboard camera calibration and image flattening (undistortion)",
       "  pg-calib calibrate --images 'shots/left*.jpg' --board 9x6 --square 0.025 --out left.json\n"
       "      # writes left.json, left.calibration.json and its .coverage.png / .distortion.png\n"
       "  pg-calib calibrate --images L/ --stereo-images R/ --board 9x6 --square 0.025 --board-warp --out "
       "rig.json\n"
       "  pg-calib flatten --cameras left.json --images 'shots/*.jpg' --alpha 0 --out flat/"});
  CLI::App& app = frame.app();
  app.require_subcommand(1);
  app.fallthrough();  // the common flags (--report, --threads, ...) may follow the subcommand

  CLI::App* cal =
      app.add_subcommand("calibrate", "calibrate a camera (or a stereo pair) from checkerboard photos");
  std::vector<std::string> images, stereo_images;
  std::string board_text, detector_name = "auto", model_name = "pinhole-k3", out, report_path;
  std::string id = "camera", stereo_id = "camera_right";
  double square = 0;
  CalibrationOptions options;
  bool no_refine = false;
  cal->add_option("--images", images, "image files, folders or quoted glob patterns")->required();
  cal->add_option("--stereo-images", stereo_images,
                  "a second camera's images of the same board positions, paired in sorted order");
  cal->add_option("--board", board_text, "inner corners COLSxROWS, e.g. 9x6")->required();
  cal->add_option("--square", square, "square size in metres")->required()->check(pg::cli::positive());
  cal->add_option("--model", model_name, "pinhole-k3 (k1 k2 p1 p2 k3), rational (k1..k6, p1, p2) or fisheye")
      ->capture_default_str()
      ->check(CLI::IsMember({"pinhole-k3", "rational", "fisheye"}));
  cal->add_option("--detector", detector_name, "auto (sector-based, then classic), sb or classic")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "sb", "classic"}));
  cal->add_flag("--fix-aspect", options.fix_aspect_ratio, "hold fy / fx");
  cal->add_flag("--fix-principal-point", options.fix_principal_point, "hold cx, cy at the image centre");
  cal->add_flag("--zero-tangential", options.zero_tangential, "p1 = p2 = 0");
  cal->add_option("--max-view-rms", options.max_view_rms,
                  "drop views above this RMS in px, worst first (0: max(0.5, 3 x median))")
      ->capture_default_str()
      ->check(pg::cli::non_negative());
  cal->add_option("--corner-outliers", options.corner_outlier_sigmas,
                  "reject corners beyond this many robust sigmas (0: keep all)")
      ->capture_default_str()
      ->check(pg::cli::non_negative());
  cal->add_flag("--board-warp", options.board_warp, "model a non-flat board (2 parameters, as mrcal)");
  cal->add_flag("--no-refine", no_refine,
                "keep OpenCV's estimate (no Ceres refinement, no corner rejection)");
  cal->add_option("--out", out, "cameras JSON to write")->required();
  cal->add_option("--calibration-report", report_path,
                  "calibration report JSON (default: <out>.calibration.json); the PNGs go beside it");
  cal->add_option("--id", id, "camera id")->capture_default_str();
  cal->add_option("--stereo-id", stereo_id, "the second camera's id")->capture_default_str();

  CLI::App* flat = app.add_subcommand("flatten", "undistort images to a pinhole camera");
  std::string cameras_path, camera_id, flat_out;
  std::vector<std::string> flat_images;
  double alpha = 0;
  flat->add_option("--cameras", cameras_path, "cameras JSON (from calibrate, or any cameras file)")
      ->required();
  flat->add_option("--camera-id", camera_id,
                   "the camera to use (default: the only one, or each camera's image)");
  flat->add_option("--images", flat_images,
                   "images to flatten with that camera (default: each camera's own image)");
  flat->add_option("--alpha", alpha, "0: only valid pixels (zoom in); 1: keep every source pixel")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  flat->add_option("--out", flat_out, "output folder: flattened images (same names) and cameras.json")
      ->required();

  return frame.run(argc, argv, [&] {
    if (*cal) {
      options.refine = !no_refine;
      run_calibrate(frame, images, stereo_images, board_text, square, detector_name, model_name, options, out,
                    report_path, id, stereo_id);
    } else {
      run_flatten(frame, cameras_path, camera_id, flat_images, flat_out, alpha);
    }
  });
}
