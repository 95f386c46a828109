// pg-track: sparse correspondences across an ordered image sequence and camera recovery with bundle
// adjustment. Writes cameras.json, points.ply, tracks.json and top_view.png into --out.
#include <algorithm>
#include <cmath>
#include <iostream>

#include "common/cli.h"
#include "pg/calib/board.h"
#include "pg/camera/cameras_io.h"
#include "pg/camera/size_check.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"
#include "pg/image/exif.h"
#include "pg/image/image_io.h"
#include "pg/sfm/board_scale.h"
#include "pg/sfm/reconstruction.h"
#include "pg/sfm/sfm_outputs.h"
#include "pg/track/correspondences.h"

namespace fs = std::filesystem;

namespace {

struct Options {
  std::vector<std::string> images;
  std::string out, cameras, masks, range, intrinsics = "auto", matcher = "sift";
  double focal = 0;
  bool refine_distortion = false, no_loops = false, no_refine_positions = false;
  std::string principal_point = "auto";
  std::vector<std::string> scale;        // id_a id_b distance
  std::vector<std::string> scale_board;  // COLSxROWS square
};

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" ||
         ext == ".exr" || ext == ".bmp" || ext == ".pgm" || ext == ".ppm";
}

// A folder (its images in name order) or a list of files.
std::vector<fs::path> list_images(const std::vector<std::string>& given) {
  std::vector<fs::path> images;
  for (const std::string& g : given) {
    if (fs::is_directory(g)) {
      std::vector<fs::path> in_folder;
      for (const auto& entry : fs::directory_iterator(g))
        if (entry.is_regular_file() && is_image(entry.path())) in_folder.push_back(entry.path());
      std::sort(in_folder.begin(), in_folder.end());
      images.insert(images.end(), in_folder.begin(), in_folder.end());
    } else {
      images.push_back(g);
    }
  }
  return images;
}

// "START:COUNT" (COUNT may be empty: to the end) over the image list.
std::vector<fs::path> apply_range(const std::vector<fs::path>& images, const std::string& range) {
  if (range.empty()) return images;
  const auto colon = range.find(':');
  try {
    const std::size_t start = std::stoul(range.substr(0, colon));
    const std::size_t count = colon == std::string::npos || colon + 1 == range.size()
                                  ? images.size()
                                  : std::stoul(range.substr(colon + 1));
    if (start >= images.size())
      throw pg::UsageError(pg::str("--range starts at ", start, " but there are ", images.size(), " images"));
    return {images.begin() + start, images.begin() + std::min(images.size(), start + count)};
  } catch (const std::logic_error&) {
    throw pg::UsageError("--range must be START:COUNT, e.g. 10:50");
  }
}

// The cameras file names images relative to its own folder (formats/cameras.md), whatever the
// working directory pg-track ran in; absolute when no relative path exists.
std::string image_path_from(const fs::path& out_dir, const fs::path& image) {
  const fs::path relative =
      fs::absolute(image).lexically_normal().lexically_relative(fs::absolute(out_dir).lexically_normal());
  return relative.empty() ? fs::absolute(image).lexically_normal().string() : relative.generic_string();
}

// The calibration --cameras gives frame f: the file's one camera, or the camera with the frame's id.
const pg::Camera& given_camera(const Options& o, const pg::CameraSet& set, const pg::SequenceFrame& frame) {
  if (set.cameras.size() == 1) return set.cameras[0];
  if (const pg::Camera* c = set.find(frame.id)) return *c;
  throw pg::InputError(
      o.cameras, pg::str("has no camera with the id of image ", frame.image.string(), " ('", frame.id, "')"));
}

// What can be checked before any image is decoded, from the files' headers: each frame's camera and
// its size (with --cameras), or one size for the one self-calibrated camera, and masks of their
// images' size. Frames in a format without a size in its header are checked once decoded.
void check_frame_sizes(const Options& o, const std::vector<pg::SequenceFrame>& frames,
                       const std::optional<pg::CameraSet>& given) {
  const std::vector<std::optional<cv::Size>> sizes = pg::sequence_image_sizes(frames);
  const pg::SequenceFrame* first = nullptr;
  cv::Size first_size;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    if (given) {
      const pg::Camera& camera = given_camera(o, *given, frames[f]);
      if (sizes[f]) pg::require_camera_size(frames[f].image, sizes[f]->width, sizes[f]->height, camera);
    } else if (sizes[f] && !first) {
      first = &frames[f], first_size = *sizes[f];
    } else if (sizes[f]) {
      pg::require_same_size(frames[f].image, {frames[f].id, sizes[f]->width, sizes[f]->height},
                            {first->id, first_size.width, first_size.height});
    }
  }
}

// --scale ID_A ID_B METRES, checked against the frames before tracking.
struct ScaleSpec {
  std::string id_a, id_b;
  double metres = 0;
};

std::optional<ScaleSpec> parse_scale(const Options& o, const std::vector<pg::SequenceFrame>& frames) {
  if (o.scale.empty()) return std::nullopt;
  ScaleSpec spec{o.scale[0], o.scale[1], 0};
  try {
    std::size_t used = 0;
    spec.metres = std::stod(o.scale[2], &used);
    if (used != o.scale[2].size()) throw std::invalid_argument("trailing characters");
  } catch (const std::logic_error&) {
    throw pg::UsageError("--scale: distance \"" + o.scale[2] + "\" is not a number");
  }
  if (!(spec.metres > 0) || !std::isfinite(spec.metres))
    throw pg::UsageError(pg::str("--scale: the distance must be positive, got ", o.scale[2]));
  if (spec.id_a == spec.id_b)
    throw pg::UsageError("--scale: give two different cameras, got " + spec.id_a + " twice");
  for (const std::string& id : {spec.id_a, spec.id_b})
    if (std::none_of(frames.begin(), frames.end(), [&](const pg::SequenceFrame& f) { return f.id == id; }))
      throw pg::UsageError(pg::str("--scale: no image named ", id, " among the ", frames.size(),
                                   " tracked (ids are the file names without extension)"));
  return spec;
}

// Initial cameras: from --cameras (one camera for all frames, or one per frame id), else self-calibration.
std::vector<pg::Camera> initial_cameras(const Options& o, const std::vector<pg::SequenceFrame>& frames,
                                        const pg::TrackSet& tracks,
                                        const std::optional<pg::CameraSet>& given) {
  std::vector<pg::Camera> cameras;
  if (given) {
    for (std::size_t f = 0; f < frames.size(); ++f) {
      pg::Camera cam = given_camera(o, *given, frames[f]);
      pg::require_camera_size(frames[f].image, tracks.frames[f].width, tracks.frames[f].height, cam);
      cam.image = image_path_from(o.out, frames[f].image);
      cameras.push_back(cam);
    }
    return cameras;
  }
  const int width = tracks.frames[0].width, height = tracks.frames[0].height;
  double focal = o.focal;
  std::string source = "--focal";
  if (focal <= 0) {
    // The photos' own EXIF (median over the frames that have it), else a guess that the bundle
    // adjustment refines.
    std::vector<double> from_exif;
    for (std::size_t f = 0; f < frames.size(); ++f)
      if (auto px = pg::focal_px_from_exif(pg::read_exif_focal(frames[f].image), width, height))
        from_exif.push_back(*px);
    if (!from_exif.empty()) {
      std::nth_element(from_exif.begin(), from_exif.begin() + from_exif.size() / 2, from_exif.end());
      focal = from_exif[from_exif.size() / 2];
      source = pg::str("EXIF (", from_exif.size(), " of ", frames.size(), " images)");
    } else {
      focal = pg::default_focal_guess(width, height);
      source = "default guess (1.2 x the larger side)";
    }
  }
  pg::log::info("pg-track: initial focal length ", focal, " px from ", source);
  pg::RunReport::global().set_metric("initial_focal_px", focal);
  pg::RunReport::global().set_metric("initial_focal_source", source);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    pg::Camera c;
    c.id = frames[f].id;
    c.image = image_path_from(o.out, frames[f].image);
    c.width = tracks.frames[f].width;
    c.height = tracks.frames[f].height;
    c.intrinsics = {focal, focal, (c.width - 1) / 2.0, (c.height - 1) / 2.0};
    cameras.push_back(c);
  }
  return cameras;
}

}  // namespace

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-track",
       "sparse correspondences and camera recovery (structure from motion) for an ordered sequence",
       "pg-track --images shot/ --out track/\n"
       "pg-track --images shot/ --cameras calib.json --intrinsics fixed --matcher klt --out track/\n"
       "pg-track --images a.png b.png c.png --range 0:2 --scale a b 1.5 --out track/\n"
       "pg-track --images shot/ --scale-board 9x6 0.025 --out track/"});
  CLI::App& app = frame.app();
  Options o;
  pg::CorrespondenceOptions co;
  pg::SfmOptions so;
  app.add_option("--images", o.images, "an image folder (name order) or image files, in sequence order")
      ->required();
  app.add_option("--out", o.out, "output folder: cameras.json, points.ply, tracks.json, top_view.png")
      ->required();
  app.add_option(
      "--cameras", o.cameras,
      "intrinsics (pg-cameras, e.g. from pg-calib): one camera for all images, or one per image id");
  app.add_option("--intrinsics", o.intrinsics,
                 "auto (fixed with --cameras, else self-calibrated), fixed, or refine")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "fixed", "refine"}));
  app.add_option("--focal", o.focal,
                 "initial focal length in pixels without --cameras (default: from the images' EXIF, else 1.2 "
                 "x the larger side)")
      ->check(pg::cli::positive());
  app.add_flag("--refine-distortion", o.refine_distortion, "also refine radial k1, k2");
  app.add_option("--principal-point", o.principal_point,
                 "while intrinsics are refined: auto (one shared camera's principal point is freed in the "
                 "final adjustment and kept where that lowers the reprojection RMS by 0.5% or more; "
                 "per-image cameras keep theirs), refine (throughout), or fixed (the image centre, or "
                 "the calibration's)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "refine", "fixed"}));
  app.add_option(
      "--masks", o.masks,
      "folder of masks named like the images (<stem>.png), nonzero = ignore (moving objects, sky, rigs)");
  app.add_option("--range", o.range, "START:COUNT, track a sub-sequence of the images");
  app.add_option("--matcher", o.matcher, "sift, klt or shi-tomasi")
      ->capture_default_str()
      ->check(CLI::IsMember({"sift", "klt", "shi-tomasi"}));
  app.add_option("--downscale", co.downscale, "find features on images shrunk by this factor")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 16.0));
  app.add_option("--max-features", co.max_features,
                 "SIFT features per image (half with --matcher klt or shi-tomasi)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  app.add_option("--window", co.sequential_window, "match each image with the next N images")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_flag("--no-loops", o.no_loops, "do not match non-neighbouring images (no loop closure)");
  app.add_flag("--no-refine-positions", o.no_refine_positions,
               "keep the detector's feature positions (default: each track's observations are aligned "
               "to sub-pixel accuracy on one of them)");
  app.add_option("--max-error", so.max_reprojection_px,
                 "largest reprojection error of an inlier, pixels (the bound follows the observations' "
                 "noise below it)")
      ->capture_default_str()
      ->check(pg::cli::positive());
  app.add_option("--error-sigmas", so.bound_sigmas,
                 "after registration, the inlier bound in robust standard deviations of the "
                 "reprojection error, from 0.1 px up to --max-error (0: always --max-error)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--scale", o.scale, "ID_A ID_B METRES: scale so that these two cameras are this far apart")
      ->expected(3);
  app.add_option(
         "--scale-board", o.scale_board,
         "COLSxROWS SQUARE_METRES: scale from a checkerboard (inner corners, square size) seen in the "
         "images")
      ->expected(2);

  return frame.run(argc, argv, [&] {
    if (!o.scale.empty() && !o.scale_board.empty())
      throw pg::UsageError("give --scale or --scale-board, not both");
    std::optional<pg::calib::BoardSpec> board;
    if (!o.scale_board.empty()) {
      double square = 0;
      try {
        square = std::stod(o.scale_board[1]);
      } catch (const std::logic_error&) {
        throw pg::UsageError("--scale-board: square size \"" + o.scale_board[1] + "\" is not a number");
      }
      board = pg::calib::parse_board(o.scale_board[0], square);
    }
    std::vector<fs::path> images = apply_range(list_images(o.images), o.range);
    if (images.size() < 2)
      throw pg::UsageError(pg::str("tracking needs at least 2 images, got ", images.size()));
    for (const fs::path& p : images) frame.input(p);
    if (!o.cameras.empty()) frame.input(o.cameras);
    frame.output_dir(o.out);
    const fs::path out(o.out);
    for (const char* name : {"cameras.json", "points.ply", "tracks.json", "top_view.png"})
      frame.output(out / name);
    if (!o.masks.empty() && !fs::is_directory(o.masks))
      throw pg::InputError(o.masks, "--masks: not a folder (masks are <image stem>.png in one folder)");
    std::vector<pg::SequenceFrame> frames;
    int masked = 0;
    for (const fs::path& p : images) {
      pg::SequenceFrame f{p.stem().string(), p, {}};
      if (!o.masks.empty()) {
        const fs::path mask = fs::path(o.masks) / (p.stem().string() + ".png");
        if (fs::exists(mask)) f.mask = mask, frame.input(mask), ++masked;
      }
      for (const pg::SequenceFrame& g : frames)
        if (g.id == f.id)
          throw pg::UsageError(pg::str("two images named ", f.id, ": ", g.image.string(), ", ", p.string()));
      frames.push_back(f);
    }
    if (!o.masks.empty()) {
      pg::log::info("pg-track: ", masked, " of ", frames.size(), " images have a mask in ", o.masks);
      if (masked == 0)
        pg::log::warn("pg-track: no mask in ", o.masks, " is named like an image (<image stem>.png)");
    }
    const std::optional<ScaleSpec> scale = parse_scale(o, frames);
    std::optional<pg::CameraSet> given;
    if (!o.cameras.empty()) {
      given = pg::read_cameras(o.cameras);
      if (given->cameras.empty()) throw pg::InputError(o.cameras, "holds no camera");
    }
    check_frame_sizes(o, frames, given);

    co.method = pg::correspondence_method_from_string(o.matcher);
    co.loop_matching = !o.no_loops;
    co.refine_positions = !o.no_refine_positions;
    co.memory_budget = pg::cli::memory_budget();
    // Before any image is decoded: a budget too small for the features and one SIFT detection (or
    // KLT tracking step) fails here.
    pg::cli::require_memory(pg::correspondence_memory_bytes(frames, co),
                            pg::str("tracking ", frames.size(), " images",
                                    co.downscale > 1 ? pg::str(" at --downscale ", co.downscale) : ""));
    pg::CorrespondenceResult correspondences;
    {
      pg::ScopedTimer timer("correspondences");
      correspondences = pg::build_correspondences(frames, co);
    }
    pg::log::info("pg-track: ", correspondences.tracks.tracks.size(), " tracks over ", frames.size(),
                  " images");

    const bool per_frame = given && given->cameras.size() > 1;
    std::vector<pg::Camera> initial = initial_cameras(o, frames, correspondences.tracks, given);
    const bool refine = o.intrinsics == "refine" || (o.intrinsics == "auto" && !given);
    so.shared_intrinsics = !per_frame;
    so.refine_focal = refine;
    // Per-image intrinsics have too few observations each to place a principal point.
    so.principal_point = !refine || o.principal_point == "fixed" ? pg::PrincipalPointMode::fixed
                         : o.principal_point == "refine"         ? pg::PrincipalPointMode::refine
                         : per_frame                             ? pg::PrincipalPointMode::fixed
                                                                 : pg::PrincipalPointMode::when_better;
    so.refine_distortion = refine && o.refine_distortion;
    so.max_reprojection_px *= co.downscale;
    so.min_reprojection_px *= co.downscale;
    so.huber_px *= co.downscale;
    pg::SfmResult result;
    {
      pg::ScopedTimer timer("reconstruction");
      result = pg::reconstruct(correspondences.tracks, initial, so);
    }
    if (scale) {
      const double s = pg::scale_to_distance(result, scale->id_a, scale->id_b, scale->metres);
      pg::log::info("pg-track: scaled by ", s);
    }
    if (board) {
      std::vector<pg::Camera> posed;
      std::vector<fs::path> posed_images;
      for (std::size_t f = 0; f < frames.size(); ++f)
        if (result.registered[f]) posed.push_back(result.cameras[f]), posed_images.push_back(frames[f].image);
      pg::BoardScale scale;
      {
        pg::ScopedTimer timer("board_scale");
        scale = pg::scale_from_board(posed, posed_images, *board);
      }
      pg::scale_reconstruction(result, scale.metres_per_unit);
      pg::log::info("pg-track: scaled by ", scale.metres_per_unit, " from the board in ", scale.views,
                    " images (spread ", 100 * scale.relative_spread, "%)");
      auto& report = pg::RunReport::global();
      report.set_metric("scale_board_views", scale.used);
      report.set_metric("scale_metres_per_unit", scale.metres_per_unit);
      report.set_metric("scale_relative_spread", scale.relative_spread);
    }
    pg::color_points(result, correspondences.tracks);
    for (std::size_t t = 0; t < correspondences.tracks.tracks.size(); ++t)
      correspondences.tracks.tracks[t].point = result.track_point[t];

    pg::CameraSet cameras = pg::registered_cameras(result);
    pg::write_cameras(out / "cameras.json", cameras);
    pg::write_sparse_points(out / "points.ply", result);
    pg::write_tracks(out / "tracks.json", correspondences.tracks);
    pg::write_image(out / "top_view.png", pg::render_top_view(result));

    auto& report = pg::RunReport::global();
    report.set_metric("images", frames.size());
    report.set_metric("registered", cameras.cameras.size());
    report.set_metric("unregistered", result.unregistered);
    report.set_metric("tracks", correspondences.tracks.tracks.size());
    report.set_metric("inconsistent_observations", correspondences.inconsistent_observations);
    report.set_metric("refined_observations", correspondences.refinement.refined);
    report.set_metric("unrefined_observations", correspondences.refinement.refused);
    report.set_metric("mean_refinement_shift_px", correspondences.refinement.mean_shift_px);
    report.set_metric("principal_point_refined", result.principal_point_refined);
    report.set_metric("points", result.points.size());
    report.set_metric("reprojection_rms_px", result.rms_px);
    nlohmann::json per_camera = nlohmann::json::array();
    for (std::size_t f = 0; f < result.cameras.size(); ++f)
      per_camera.push_back({{"id", result.cameras[f].id},
                            {"registered", static_cast<bool>(result.registered[f])},
                            {"observations", result.frame_observations[f]},
                            {"rms_px", result.frame_rms_px[f]}});
    report.set_metric("cameras", per_camera);
    const pg::Camera& first = cameras.cameras.front();
    report.set_metric("focal_px", first.intrinsics.fx);
    std::cout << "registered " << cameras.cameras.size() << "/" << frames.size() << " images, "
              << result.points.size() << " points, reprojection RMS " << result.rms_px << " px, focal "
              << first.intrinsics.fx << " px\n";
    if (!result.unregistered.empty()) {
      std::string list;
      for (const std::string& id : result.unregistered) list += (list.empty() ? "" : ", ") + id;
      pg::log::warn("pg-track: not registered: ", list);
      std::cout << "not registered: " << list << "\n";
      if (o.no_loops)
        pg::log::warn(
            "pg-track: --no-loops matches only neighbouring images; where the order of the "
            "images jumps (views not shot in sequence), run without it");
    }
  });
}
