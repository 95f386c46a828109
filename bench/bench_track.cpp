// pg-track's camera recovery against COLMAP (CPU, `colmap` on PATH) on the same images and
// intrinsics, in one run: registered images, centre error (% of the path extent, after similarity
// alignment) and rotation error against ground truth (after that alignment, and orientation-aligned),
// wall time of each (features + matching + mapping) and the time ratio. COLMAP is skipped with a
// message when it is not installed. To tell the front end (features, matching, tracks) from the
// mapper, pg's mapper is also run on COLMAP's final tracks ("pg-map", "pg-map4").
// Where both ran, the two tools' cameras are compared with each other, and each tool's tracks are
// measured under the true cameras, pg's and COLMAP's: where the tools agree far better with each
// other than with the truth, and the true cameras explain the tracks worse than either tool's, the
// errors against the truth are mostly the truth's own.
//   bench_track [data folder, default $PG_DATA_DIR or ../shared/data] [set names: temple-sparse,
//   temple-ring, herz-half, herz-full, entry-half, entry-full; default all]
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <tuple>

#include "pg/build_info.h"
#include "pg/eval/camera_eval.h"
#include "pg/eval/orientation_error.h"
#include "pg/eval/track_eval.h"
#include "pg/eval/truth_import.h"
#include "pg/image/huge_page_mats.h"
#include "pg/sfm/reconstruction.h"
#include "pg/sfm/sfm_outputs.h"
#include "pg/track/correspondences.h"

namespace fs = std::filesystem;

namespace {

struct Dataset {
  std::string name;
  fs::path images;  // folder holding exactly the images of `truth`, in order
  pg::CameraSet truth;
};

struct Outcome {
  bool ran = false;
  std::size_t registered = 0;
  double median_centre_percent = 0, median_rotation_deg = 0, focal_error_percent = 0, seconds = 0;
  double median_orientation_deg = 0;  // orientation-aligned (pg/eval/orientation_error.h)
  pg::CameraSet cameras;              // the registered cameras
  pg::TrackSet tracks;                // the tool's own tracks (pg's, or COLMAP's final ones)
};

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Outcome evaluate(const pg::CameraSet& estimate, const pg::CameraSet& truth, double seconds) {
  Outcome o;
  o.ran = true;
  o.seconds = seconds;
  o.registered = estimate.cameras.size();
  o.cameras = estimate;
  if (estimate.cameras.size() < 3) return o;
  const pg::CameraEvalResult e = pg::evaluate_cameras(estimate, truth);
  double extent = 0;
  for (const auto& a : truth.cameras)
    for (const auto& b : truth.cameras)
      extent = std::max(extent, (a.cam_from_world.centre() - b.cam_from_world.centre()).norm());
  o.median_centre_percent = 100 * e.centre_error.median / extent;
  o.median_rotation_deg = e.rotation_error_deg.median;
  o.focal_error_percent = 100 * e.focal_relative_error.median;
  std::vector<double> orientation = pg::orientation_aligned_rotation_errors_deg(estimate, truth);
  std::sort(orientation.begin(), orientation.end());
  o.median_orientation_deg = orientation[orientation.size() / 2];
  return o;
}

// The starting cameras of a run: the true intrinsics, or pg-track's default focal guess.
std::vector<pg::Camera> initial_cameras(const Dataset& d, bool known) {
  std::vector<pg::Camera> initial;
  for (const pg::Camera& c : d.truth.cameras) {
    pg::Camera guess = c;
    if (!known) {
      const double f = pg::default_focal_guess(c.width, c.height);
      guess.intrinsics = {f, f, (c.width - 1) / 2.0, (c.height - 1) / 2.0};
      guess.distortion = {};
    }
    initial.push_back(guess);
  }
  return initial;
}

pg::SfmOptions sfm_options(bool known) {
  pg::SfmOptions options;
  options.shared_intrinsics = !known;
  options.refine_focal = !known;
  if (!known) options.principal_point = pg::PrincipalPointMode::when_better;  // pg-track's default
  return options;
}

Outcome run_pg(const Dataset& d, bool known) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<pg::SequenceFrame> frames;
  for (const pg::Camera& c : d.truth.cameras)
    frames.push_back({c.id, d.images / fs::path(c.image).filename(), {}});
  const pg::CorrespondenceResult corr = pg::build_correspondences(frames, {});
  const pg::SfmResult result = pg::reconstruct(corr.tracks, initial_cameras(d, known), sfm_options(known));
  Outcome o = evaluate(pg::registered_cameras(result), d.truth, seconds_since(start));
  o.tracks = corr.tracks;
  return o;
}

bool have_colmap() {
  return std::system("colmap help > /dev/null 2>&1") == 0;
}

int run_command(const std::string& command) {
  return std::system((command + " > /dev/null 2>&1").c_str());
}

struct ColmapModel {
  pg::CameraSet cameras;
  pg::TrackSet tracks;  // its points' observations, frames in the order of the truth
};

// COLMAP's pixel (0, 0) is the corner of the top-left pixel; pg's is its centre.
ColmapModel read_colmap_text(const fs::path& folder, const pg::CameraSet& truth) {
  ColmapModel model;
  for (const pg::Camera& c : truth.cameras) model.tracks.frames.push_back({c.id, c.image, c.width, c.height});
  std::map<int, pg::Intrinsics> intrinsics;
  std::ifstream cams(folder / "cameras.txt");
  for (std::string line; std::getline(cams, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    int id, w, h;
    std::string model_name;
    in >> id >> model_name >> w >> h;
    std::vector<double> p;
    for (double x; in >> x;) p.push_back(x);
    if (model_name == "PINHOLE")
      intrinsics[id] = {p[0], p[1], p[2] - 0.5, p[3] - 0.5};
    else
      intrinsics[id] = {p[0], p[0], p[1] - 0.5, p[2] - 0.5};  // SIMPLE_RADIAL, SIMPLE_PINHOLE, RADIAL
  }
  std::map<long, pg::Track> tracks;
  std::ifstream images(folder / "images.txt");
  for (std::string line; std::getline(images, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    int id, camera;
    double qw, qx, qy, qz, tx, ty, tz;
    std::string name;
    in >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> camera >> name;
    std::getline(images, line);  // the 2D points line: x y point3D_id (-1: none)
    const std::string stem = fs::path(name).stem().string();
    const pg::Camera* t = truth.find(stem);
    if (!t) continue;
    const int frame = static_cast<int>(t - truth.cameras.data());  // tracks.frames follows the truth
    pg::Camera c = *t;
    c.intrinsics = intrinsics[camera];
    c.cam_from_world.rotation = Eigen::Quaterniond(qw, qx, qy, qz).normalized();
    c.cam_from_world.translation = {tx, ty, tz};
    model.cameras.cameras.push_back(c);
    std::istringstream points(line);
    double x, y;
    long point;
    while (points >> x >> y >> point)
      if (point >= 0)
        tracks[point].observations.push_back(
            {frame, static_cast<float>(x - 0.5), static_cast<float>(y - 0.5)});
  }
  for (auto& [point, track] : tracks) {
    std::sort(track.observations.begin(), track.observations.end(),
              [](const pg::TrackObservation& a, const pg::TrackObservation& b) { return a.frame < b.frame; });
    model.tracks.tracks.push_back(std::move(track));
  }
  return model;
}

// pg's mapper on COLMAP's final tracks: with the same observations, what is left of a difference
// between the tools is the mapper's. `colmap_bounds` uses COLMAP's mapper settings (a fixed 4 px
// outlier bound, squared loss) instead of pg's (10 sigma of the observations' noise, at most 1.5 px,
// with a Huber scale in proportion), which suit pg's more precise observations. The tracks have
// already been filtered by COLMAP's mapper.
Outcome run_pg_on_tracks(const Dataset& d, bool known, const pg::TrackSet& tracks, bool colmap_bounds) {
  const auto start = std::chrono::steady_clock::now();
  pg::SfmOptions options = sfm_options(known);
  if (colmap_bounds) {
    options.max_reprojection_px = 4;
    options.bound_sigmas = 0;  // a fixed bound, as COLMAP's
    options.huber_px = 1e6;    // no observation within the bound reaches it: squared loss
  }
  try {
    const pg::SfmResult result = pg::reconstruct(tracks, initial_cameras(d, known), options);
    return evaluate(pg::registered_cameras(result), d.truth, seconds_since(start));
  } catch (const std::exception& e) {
    std::cerr << "pg's mapper on COLMAP's tracks of " << d.name << ": " << e.what() << "\n";
    return {};
  }
}

struct ColmapOutcome {
  Outcome colmap;
  // pg's mapper on COLMAP's tracks, with pg's and with COLMAP's outlier settings.
  Outcome pg_mapper, pg_mapper_colmap_bounds;
};

ColmapOutcome run_colmap(const Dataset& d, bool known, const fs::path& work) {
  fs::remove_all(work);
  fs::create_directories(work / "sparse");
  const std::string db = (work / "db.db").string(), images = d.images.string();
  const auto start = std::chrono::steady_clock::now();
  std::string extract = "colmap feature_extractor --database_path " + db + " --image_path " + images +
                        " --ImageReader.single_camera 1 --SiftExtraction.use_gpu 0";
  if (known) {
    const pg::Intrinsics& k = d.truth.cameras[0].intrinsics;
    std::ostringstream params;
    params << std::setprecision(17) << k.fx << "," << k.fy << "," << k.cx + 0.5 << "," << k.cy + 0.5;
    extract += " --ImageReader.camera_model PINHOLE --ImageReader.camera_params " + params.str();
  }
  if (run_command(extract) != 0) return {};
  // Exhaustive matching: what COLMAP's users run on small sets, and what closes a ring.
  if (run_command("colmap exhaustive_matcher --database_path " + db + " --SiftMatching.use_gpu 0") != 0)
    return {};
  std::string map = "colmap mapper --database_path " + db + " --image_path " + images + " --output_path " +
                    (work / "sparse").string();
  if (known)
    map +=
        " --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0 "
        "--Mapper.ba_refine_extra_params 0";
  if (run_command(map) != 0) return {};
  const double seconds = seconds_since(start);
  // The largest model.
  ColmapModel best;
  for (const auto& entry : fs::directory_iterator(work / "sparse")) {
    const fs::path txt = work / ("txt_" + entry.path().filename().string());
    fs::create_directories(txt);
    run_command("colmap model_converter --input_path " + entry.path().string() + " --output_path " +
                txt.string() + " --output_type TXT");
    ColmapModel model = read_colmap_text(txt, d.truth);
    if (model.cameras.cameras.size() > best.cameras.cameras.size()) best = std::move(model);
  }
  ColmapOutcome out;
  out.colmap = evaluate(best.cameras, d.truth, seconds);
  out.colmap.tracks = best.tracks;
  if (!best.tracks.tracks.empty()) {
    out.pg_mapper = run_pg_on_tracks(d, known, best.tracks, false);
    out.pg_mapper_colmap_bounds = run_pg_on_tracks(d, known, best.tracks, true);
  }
  return out;
}

// Images resized by `factor` into `folder` (for the half-resolution sets).
Dataset resized(const Dataset& d, double factor, const fs::path& folder, const std::string& name) {
  Dataset out{name, folder, {}};
  fs::create_directories(folder);
  for (const pg::Camera& c : d.truth.cameras) {
    const fs::path image = d.images / fs::path(c.image).filename();
    const fs::path target = folder / image.filename();
    if (!fs::exists(target)) {
      cv::Mat m = cv::imread(image.string(), cv::IMREAD_COLOR), small;
      cv::resize(m, small, cv::Size(), factor, factor, cv::INTER_AREA);
      cv::imwrite(target.string(), small, {cv::IMWRITE_JPEG_QUALITY, 98});
    }
    out.truth.cameras.push_back(pg::resized_camera(c, factor));
  }
  return out;
}

// A folder with only the images named by the truth (the Middlebury folders hold other files too).
Dataset linked(const std::string& name, const fs::path& source, const pg::CameraSet& truth,
               const fs::path& folder) {
  fs::create_directories(folder);
  for (const pg::Camera& c : truth.cameras) {
    const fs::path target = folder / fs::path(c.image).filename();
    if (!fs::exists(target)) fs::create_symlink(fs::absolute(source / c.image), target);
  }
  return {name, folder, truth};
}

void print_row(const std::string& set, const std::string& mode, const std::string& tool, const Outcome& o,
               std::size_t frames) {
  std::cout << std::left << std::setw(22) << set << std::setw(11) << mode << std::setw(9) << tool;
  if (!o.ran) {
    std::cout << "failed\n";
    return;
  }
  std::cout << std::right << std::setw(3) << o.registered << "/" << std::left << std::setw(4) << frames
            << std::fixed << std::setprecision(4) << std::setw(11) << o.median_centre_percent << std::setw(11)
            << o.median_rotation_deg << std::setw(11) << o.median_orientation_deg << std::setprecision(2)
            << std::setw(9) << o.focal_error_percent << std::setprecision(1) << o.seconds << " s\n";
}

// Median distance (px) between the observations of `tracks` and their points triangulated with
// `cameras`. Observations in frames without a camera there (not registered) are left out.
double median_track_error(const pg::TrackSet& tracks, const pg::CameraSet& cameras) {
  std::vector<pg::Camera> ordered;
  std::vector<bool> present;
  for (const pg::TrackFrame& f : tracks.frames) {
    const pg::Camera* c = cameras.find(f.id);
    present.push_back(c != nullptr);
    ordered.push_back(c ? *c : cameras.cameras.front());  // a stand-in no observation uses
  }
  pg::TrackSet seen;
  seen.frames = tracks.frames;
  for (const pg::Track& t : tracks.tracks) {
    pg::Track kept;
    for (const pg::TrackObservation& o : t.observations)
      if (present[o.frame]) kept.observations.push_back(o);
    if (kept.observations.size() >= 2) seen.tracks.push_back(std::move(kept));
  }
  return pg::track_agreement(seen, ordered).observation_error_px.median;
}

// How far apart the two tools' cameras are, and how well each camera set (and the truth's) explains
// each tool's tracks (see the top of this file).
void print_agreement(const Outcome& ours, const Outcome& theirs, const pg::CameraSet& truth) {
  if (ours.cameras.cameras.size() < 3 || theirs.cameras.cameras.size() < 3) return;
  const Outcome between = evaluate(ours.cameras, theirs.cameras, 0);
  std::cout << std::left << std::setw(42) << "" << std::fixed << std::setprecision(4)
            << "pg vs colmap: centre " << between.median_centre_percent << "%, rot "
            << between.median_rotation_deg << " deg\n";
  for (const auto& [name, tracks] :
       {std::pair{"pg's", &ours.tracks}, std::pair{"colmap's", &theirs.tracks}}) {
    if (tracks->tracks.empty()) continue;
    std::cout << std::left << std::setw(42) << "" << std::setprecision(3) << "median error of " << name
              << " tracks (px) under the truth " << median_track_error(*tracks, truth) << ", pg "
              << median_track_error(*tracks, ours.cameras) << ", colmap "
              << median_track_error(*tracks, theirs.cameras) << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  pg::use_huge_pages_for_large_mats();  // as every pg-* tool does
  const char* env = std::getenv("PG_DATA_DIR");
  const fs::path data = argc > 1 ? fs::path(argv[1]) : fs::path(env ? env : pg::build_info::default_data_dir);
  std::set<std::string> wanted;
  for (int i = 2; i < argc; ++i) wanted.insert(argv[i]);
  auto want = [&](const std::string& name) { return wanted.empty() || wanted.count(name) > 0; };
  const fs::path work = fs::temp_directory_path() / "pg-bench-track";
  fs::create_directories(work);
  const bool colmap = have_colmap();
  if (!colmap) std::cout << "colmap not found on PATH: COLMAP is skipped (Debian package 'colmap')\n";

  std::vector<Dataset> sets;
  const fs::path multiview = data / "multiview";
  // templeRing's images in ../shared/data are stored turned from its parameters' frames.
  const std::function<int(const std::string&)> unturned = nullptr,
                                               temple_ring = pg::temple_ring_quarter_turns;
  for (const auto& [name, folder, par, turns] :
       {std::tuple{"temple-sparse", "templeSparseRing", "templeSR_par.txt", unturned},
        std::tuple{"temple-ring", "templeRing", "templeR_par.txt", temple_ring}})
    if (want(name) && fs::exists(multiview / folder / par))
      sets.push_back(linked(name, multiview / folder,
                            pg::import_middlebury_par(multiview / folder / par, turns),
                            work / "images" / name));
  for (const auto& [name, folder] : {std::pair{"herz", "Herz-Jesus-P8"}, std::pair{"entry", "entry-P10"}}) {
    const fs::path root = multiview / "strecha" / folder;
    if (!fs::exists(root)) continue;
    const Dataset full{std::string(name) + "-full", root / "images",
                       pg::import_strecha_cameras(root / "gt_dense_cameras", "images")};
    if (want(std::string(name) + "-half"))
      sets.push_back(
          resized(full, 0.5, work / "images" / (std::string(name) + "-half"), std::string(name) + "-half"));
    if (want(std::string(name) + "-full")) sets.push_back(full);
  }
  if (sets.empty()) {
    std::cout << "no data found under " << data << "\n";
    return 0;
  }
  if (colmap)
    std::cout << "pg-map: pg's mapper on COLMAP's final tracks (time: mapping only); pg-map4: the same with "
                 "COLMAP's outlier bound (4 px) and squared loss\n";
  std::cout
      << "set                   mode       tool     registered centre%    rot(deg)   orient(deg) focal% "
         "  time\n";
  for (const Dataset& d : sets)
    for (const bool known : {false, true}) {
      const std::string mode = known ? "known K" : "self-cal";
      const Outcome ours = run_pg(d, known);
      print_row(d.name, mode, "pg", ours, d.truth.cameras.size());
      if (!colmap) continue;
      const ColmapOutcome colmap_run = run_colmap(d, known, work / "colmap");
      const Outcome& theirs = colmap_run.colmap;
      print_row(d.name, mode, "colmap", theirs, d.truth.cameras.size());
      if (theirs.ran) {
        print_row(d.name, mode, "pg-map", colmap_run.pg_mapper, d.truth.cameras.size());
        print_row(d.name, mode, "pg-map4", colmap_run.pg_mapper_colmap_bounds, d.truth.cameras.size());
      }
      if (!theirs.ran || !ours.ran) continue;
      print_agreement(ours, theirs, d.truth);
      std::cout << std::left << std::setw(42) << ""
                << "time ratio pg/colmap " << std::setprecision(2) << ours.seconds / theirs.seconds
                << ", centre error ratio "
                << (theirs.median_centre_percent > 0
                        ? ours.median_centre_percent / theirs.median_centre_percent
                        : 0)
                << "\n";
    }
  return 0;
}
