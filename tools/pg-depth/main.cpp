// pg-depth: depth maps from image pairs by variational optical flow and triangulation.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>

#include "common/cli.h"
#include "pg/camera/cameras_io.h"
#include "pg/camera/size_check.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/provenance.h"
#include "pg/core/run_report.h"
#include "pg/depth/depth_geometry.h"
#include "pg/depth/depth_memory.h"
#include "pg/depth/depth_pair.h"
#include "pg/flow/flow_color.h"
#include "pg/flow/flow_memory.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/point_cloud.h"

namespace fs = std::filesystem;

namespace {

struct Options {
  std::string cameras, out_dir, masks, range, preset = "balanced", mode = "epipolar";
  std::vector<std::string> pairs;
  double scale = 1.0, alpha = 0, pyramid_factor = 0, clg_rho = 0, search_range = 0;
  bool keep_all = false, fill_occlusions = false, ply = false, mesh = false, preview = false,
       flow_png = false;
  pg::DepthFilterOptions filter;
};

struct PairIds {
  std::string reference, other;
};

std::vector<PairIds> parse_pairs(const Options& o, const pg::CameraSet& set) {
  std::vector<PairIds> pairs;
  for (const std::string& text : o.pairs) {
    const auto colon = text.find(':');
    if (colon == std::string::npos) throw pg::UsageError("--pair '" + text + "': expected REF:OTHER");
    pairs.push_back({text.substr(0, colon), text.substr(colon + 1)});
  }
  if (pairs.empty()) {  // consecutive cameras in file order
    for (std::size_t i = 0; i + 1 < set.cameras.size(); ++i)
      pairs.push_back({set.cameras[i].id, set.cameras[i + 1].id});
    if (pairs.empty())
      throw pg::InputError(
          o.cameras, pg::str("holds ", set.cameras.size(), set.cameras.size() == 1 ? " camera" : " cameras",
                             ": no pair of consecutive cameras (give --pair REF:OTHER)"));
  }
  for (const PairIds& p : pairs)
    for (const std::string& id : {p.reference, p.other})
      if (!set.find(id)) throw pg::InputError(o.cameras, "no camera '" + id + "' (named by a pair)");
  if (!o.range.empty()) {  // START,COUNT for a farm chunk
    std::size_t start = 0, count = 0;
    char comma = 0;
    std::istringstream in(o.range);
    if (!(in >> start >> comma >> count) || comma != ',' || !in.eof() || count == 0)
      throw pg::UsageError("--range '" + o.range + "': expected START,COUNT with COUNT at least 1");
    if (start >= pairs.size())
      throw pg::UsageError(pg::str("--range starts at ", start, " but there are ", pairs.size(), " pairs"));
    pairs = std::vector<PairIds>(pairs.begin() + static_cast<long>(start),
                                 pairs.begin() + static_cast<long>(std::min(pairs.size(), start + count)));
  }
  return pairs;
}

fs::path image_path(const fs::path& cameras_file, const pg::Camera& camera) {
  if (camera.image.empty()) throw pg::InputError(cameras_file, "camera '" + camera.id + "' names no image");
  const fs::path image = camera.image;
  return image.is_absolute() ? image : cameras_file.parent_path() / image;
}

// The camera's mask in --masks; empty when there is none for it.
fs::path mask_path(const Options& o, const pg::Camera& camera) {
  if (o.masks.empty()) return {};
  fs::path path = fs::path(o.masks) / (camera.id + ".png");
  return fs::exists(path) ? path : fs::path();
}

cv::Mat1b read_mask(const Options& o, const pg::Camera& camera) {
  const fs::path path = mask_path(o, camera);
  if (path.empty()) return {};
  cv::Mat1b mask = pg::read_image(path, pg::ReadMode::unchanged);
  pg::require_camera_size(path, mask.cols, mask.rows, camera, "mask");
  return mask;
}

cv::Mat read_view(const fs::path& path, const pg::Camera& camera) {
  cv::Mat image = pg::read_image(path);
  pg::require_camera_size(path, image.cols, image.rows, camera, "image");
  return image;
}

// Every pair's inputs checked before any pair is computed, from the files' headers, so that a farm
// chunk with one wrong image fails in seconds rather than after its earlier pairs: the cameras have a
// baseline, the images and masks exist and have their camera's size. Formats whose header cannot be
// read without decoding are checked when decoded (read_view, read_mask).
void check_pair_inputs(const Options& o, const pg::CameraSet& set, const std::vector<PairIds>& pairs) {
  const auto check_header = [](const fs::path& path, const pg::Camera& camera, const char* what) {
    if (const std::optional<cv::Size> size = pg::peek_image_size(path))
      pg::require_camera_size(path, size->width, size->height, camera, what);
  };
  for (const PairIds& ids : pairs) {
    const pg::Camera& reference = *set.find(ids.reference);
    const pg::Camera& other = *set.find(ids.other);
    if ((reference.cam_from_world.centre() - other.cam_from_world.centre()).norm() == 0)
      throw pg::InputError(o.cameras, "cameras '" + ids.reference + "' and '" + ids.other +
                                          "' have the same centre: no baseline to triangulate");
    if (reference.width != other.width || reference.height != other.height)
      throw pg::InputError(o.cameras,
                           pg::str("cameras '", ids.reference, "' (", reference.width, "x", reference.height,
                                   ") and '", ids.other, "' (", other.width, "x", other.height,
                                   ") differ in size; a pair's views must have one size"));
    for (const pg::Camera* camera : {&reference, &other}) {
      check_header(image_path(o.cameras, *camera), *camera, "image");
      if (const fs::path mask = mask_path(o, *camera); !mask.empty()) check_header(mask, *camera, "mask");
    }
  }
}

// --max-memory: every pair's estimate (from its cameras, before any image is decoded) must fit, so a
// job that cannot finish fails with exit code 5 before it writes anything.
void require_memory(const Options& o, const pg::CameraSet& set, const std::vector<PairIds>& pairs,
                    const pg::DepthPairOptions& options) {
  for (const PairIds& ids : pairs) {
    const pg::Camera& reference = *set.find(ids.reference);
    const pg::Camera& other = *set.find(ids.other);
    const pg::Camera working = options.scale == 1 ? reference : pg::resized_camera(reference, options.scale);
    const std::uint64_t bytes = pg::depth_pair_memory_bytes(
        reference, other, pg::decoded_image_bytes_per_pixel(image_path(o.cameras, reference)),
        pg::max_flow_channels, options);
    pg::cli::require_memory(bytes, pg::str("depth for pair ", ids.reference, "/", ids.other, " at ",
                                           working.width, "x", working.height));
  }
}

pg::DepthPairOptions pair_options(const Options& o) {
  pg::DepthPairOptions options;
  options.flow = pg::FlowOptions::preset(o.preset);
  if (o.alpha > 0) (o.mode == "epipolar" ? options.flow.epipolar_alpha : options.flow.alpha) = o.alpha;
  if (o.pyramid_factor > 0) options.flow.pyramid_factor = o.pyramid_factor;
  options.flow.clg_rho = o.clg_rho;
  options.flow.search_range = o.search_range;
  if (o.mode != "epipolar" && o.mode != "free") throw pg::UsageError("--mode must be epipolar or free");
  options.epipolar = o.mode == "epipolar";
  options.scale = o.scale;
  options.filter = o.filter;
  options.filter.keep_all = o.keep_all;
  options.fill_occlusions = o.fill_occlusions;
  options.check();
  return options;
}

}  // namespace

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-depth", "depth maps of image pairs by variational optical flow and triangulation",
       "  pg-depth --cameras shot/synth/cameras.json --out-dir shot/depth --preview\n"
       "  pg-depth --cameras c.json --pair view_000:view_001 --scale 0.5 --ply --mesh --out-dir d\n"
       "  pg-depth --cameras c.json --range 8,4 --out-dir d      # pairs 8..11 (a farm chunk)\n"
       "  pg-depth --cameras c.json --max-memory 8G --out-dir d  # exit 5 before decoding if a pair needs "
       "more"});
  Options o;
  CLI::App& app = frame.app();
  app.add_option("--cameras", o.cameras, "cameras file (pg-cameras); images are its cameras' \"image\" paths")
      ->required();
  app.add_option("--out-dir", o.out_dir, "folder for REF-OTHER.exr (and the optional outputs)")->required();
  app.add_option("--pair", o.pairs,
                 "REF:OTHER camera ids (repeatable); default: consecutive cameras in file order");
  app.add_option("--range", o.range, "START,COUNT: only these pairs of the list (farm chunks)");
  app.add_option("--masks", o.masks, "folder of masks <camera id>.png, nonzero = ignore");
  app.add_option("--mode", o.mode, "flow mode: epipolar (static scenes, default) or free 2-D flow");
  app.add_option("--preset", o.preset, "flow settings: fast, balanced (default) or accurate");
  app.add_option("--alpha", o.alpha, "flow smoothness weight (default from the preset: 3 epipolar, 8 free)");
  app.add_option("--pyramid-factor", o.pyramid_factor, "size ratio between pyramid levels, in [0.5, 1)");
  app.add_option("--clg", o.clg_rho, "combined local-global data term with this integration sigma (pixels)");
  app.add_option("--search-range", o.search_range,
                 "epipolar mode: start from a discrete search along each line within this fraction of the "
                 "image width (large motions of small structures; 0 = coarse to fine only, the default)");
  app.add_option("--scale", o.scale, "resolution of the computation relative to the images, in (0, 1]");
  app.add_option("--min-angle", o.filter.min_triangulation_angle_deg,
                 "minimum triangulation angle, degrees (1)");
  app.add_option("--max-fb-error", o.filter.max_fb_error, "forward-backward flow error limit, pixels (1)");
  app.add_option("--min-texture", o.filter.min_texture,
                 "local RMS intensity gradient below which a pixel is rejected (0.004; 0 = off)");
  app.add_option("--max-grazing", o.filter.max_grazing_angle_deg,
                 "maximum normal-to-ray angle, degrees (80)");
  app.add_option("--max-depth-jump", o.filter.max_depth_jump,
                 "relative depth step marking a discontinuity (0.04)");
  app.add_flag("--keep-all", o.keep_all,
               "keep every triangulated depth; rejections only zero the confidence");
  app.add_flag("--fill-occlusions", o.fill_occlusions,
               "epipolar mode: pixels failing the forward-backward check (hidden in the other view) take "
               "their epipolar line's background depth, at half confidence, instead of being rejected");
  app.add_flag("--ply", o.ply, "also write REF-OTHER.ply: the valid points with normals and colours");
  app.add_flag("--mesh", o.mesh, "also write REF-OTHER-mesh.ply: the mesh of the depth grid");
  app.add_flag("--preview", o.preview, "also write REF-OTHER-depth.png: a colour-mapped depth preview");
  app.add_flag("--flow-png", o.flow_png,
               "also write REF-OTHER-flow.png: the flow (formats/flow-visualisation.md)");
  return frame.run(argc, argv, [&] {
    frame.input(o.cameras);
    if (!o.masks.empty()) frame.input_dir(o.masks);
    const pg::DepthPairOptions options = pair_options(o);
    const pg::CameraSet set = pg::read_cameras(o.cameras);
    const std::vector<PairIds> pairs = parse_pairs(o, set);
    check_pair_inputs(o, set, pairs);
    require_memory(o, set, pairs, options);
    // Every pair's files are declared before any output, so no pair overwrites a later pair's input;
    // each output's provenance names its own pair's files.
    const auto pair_files = [&](const PairIds& ids) {
      std::vector<fs::path> files;
      for (const std::string& id : {ids.reference, ids.other}) {
        const pg::Camera& camera = *set.find(id);
        files.push_back(image_path(o.cameras, camera));
        if (fs::path mask = mask_path(o, camera); !mask.empty()) files.push_back(mask);
      }
      return files;
    };
    std::vector<fs::path> declared;
    for (const PairIds& ids : pairs)
      for (const fs::path& file : pair_files(ids))
        if (std::find(declared.begin(), declared.end(), file) == declared.end())
          frame.input(file), declared.push_back(file);
    frame.output_dir(o.out_dir);
    const fs::path out_dir = o.out_dir;
    // Every pair's outputs, declared before the first is computed: a pair given twice, or two pairs
    // whose ids join to one name (a-b:c, a:b-c), fail at once rather than after the first pair.
    const auto output = [&](const PairIds& ids, const char* suffix) {
      return out_dir / (ids.reference + "-" + ids.other + suffix);
    };
    for (const PairIds& ids : pairs)
      for (const auto& [suffix, wanted] :
           {std::pair{".exr", true}, std::pair{".ply", o.ply}, std::pair{"-mesh.ply", o.mesh},
            std::pair{"-depth.png", o.preview}, std::pair{"-flow.png", o.flow_png}})
        if (wanted) frame.output(output(ids, suffix));
    std::size_t valid = 0, total = 0, filled = 0;
    double flow_seconds = 0, triangulation_seconds = 0;
    for (const PairIds& ids : pairs) {
      pg::DepthPairInput input;
      input.reference = *set.find(ids.reference);
      input.other = *set.find(ids.other);
      const fs::path ref_path = image_path(o.cameras, input.reference);
      const fs::path other_path = image_path(o.cameras, input.other);
      pg::Provenance provenance = pg::Provenance::current();
      provenance.inputs = {o.cameras};
      for (const fs::path& file : pair_files(ids)) provenance.inputs.push_back(file.string());
      input.reference_image = read_view(ref_path, input.reference);
      input.other_image = read_view(other_path, input.other);
      input.reference_mask = read_mask(o, input.reference);
      input.other_mask = read_mask(o, input.other);
      if (input.reference_image.channels() != input.other_image.channels())
        throw pg::InputError(other_path, "has a different channel count from " + ref_path.string());

      pg::DepthPairResult result = pg::compute_depth_pair(input, options);
      result.depth.map.provenance = provenance;
      const std::string stem = ids.reference + "-" + ids.other;
      const fs::path exr = output(ids, ".exr");
      pg::write_depth_exr(exr, result.depth.map);
      const cv::Mat colours =
          input.reference_image.depth() == CV_8U && options.scale == 1 ? input.reference_image : cv::Mat();
      if (o.ply) {
        const fs::path path = output(ids, ".ply");
        pg::PointCloud cloud = pg::depth_point_cloud(result.depth.map, colours);
        cloud.provenance = provenance;
        pg::write_point_cloud_ply(path, cloud);
      }
      if (o.mesh) {
        const fs::path path = output(ids, "-mesh.ply");
        pg::Mesh mesh = pg::depth_grid_mesh(result.depth.map, colours);
        mesh.provenance = provenance;
        pg::write_mesh(path, mesh);
      }
      if (o.preview) {
        const fs::path path = output(ids, "-depth.png");
        pg::write_depth_preview_png(path, result.depth.map);
      }
      if (o.flow_png) {
        const fs::path path = output(ids, "-flow.png");
        pg::write_image(path, pg::flow_to_color(result.flow));
      }
      const auto& r = result.depth.rejections;
      pg::log::info(pg::str(stem, ": ", result.depth.valid, " valid pixels (",
                            100 * result.depth.valid_fraction(), "%); rejected: masked ", r.masked,
                            ", untriangulated ", r.untriangulated, ", inconsistent ", r.inconsistent,
                            ", small angle ", r.small_angle, ", epipolar ", r.epipolar, ", grazing ",
                            r.grazing, ", discontinuity ", r.discontinuity, ", textureless ", r.textureless));
      if (options.fill_occlusions) pg::log::info(pg::str(stem, ": ", result.filled, " hidden pixels filled"));
      valid += result.depth.valid;
      filled += result.filled;
      total += result.depth.map.depth.total();
      flow_seconds += result.flow_seconds;
      triangulation_seconds += result.triangulation_seconds;
    }
    pg::RunReport& report = pg::RunReport::global();
    report.set_metric("pairs", pairs.size());
    report.set_metric("valid_fraction", total > 0 ? static_cast<double>(valid) / total : 0.0);
    if (options.fill_occlusions)
      report.set_metric("filled_fraction", total > 0 ? static_cast<double>(filled) / total : 0.0);
    report.add_timing("flow", flow_seconds);
    report.add_timing("triangulation", triangulation_seconds);
  });
}
