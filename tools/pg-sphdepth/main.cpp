// pg-sphdepth: range map and sphere-grid mesh from a pair of equirectangular (HDRI) panoramas.
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/cli.h"
#include "pg/camera/cameras_io.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/provenance.h"
#include "pg/core/run_report.h"
#include "pg/flow/flow_memory.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/spherical/room_planes.h"
#include "pg/spherical/sphere_depth.h"
#include "pg/spherical/sphere_depth_memory.h"
#include "pg/spherical/sphere_mesh.h"

namespace fs = std::filesystem;

namespace {

struct Options {
  std::string reference, other, offset, cameras, rig, out_dir, stem, preset = "balanced", mesh_format = "ply";
  double alpha = 0;
  pg::SphereDepthOptions depth;
  pg::SphereMeshOptions mesh;
};

Eigen::Vector3d parse_offset(const std::string& text) {
  Eigen::Vector3d offset;
  char comma1 = 0, comma2 = 0;
  std::istringstream in(text);
  if (!(in >> offset.x() >> comma1 >> offset.y() >> comma2 >> offset.z()) || comma1 != ',' || comma2 != ',' ||
      !in.eof() || !offset.allFinite())
    throw pg::UsageError("--offset '" + text + "': expected X,Y,Z in metres (camera frame: y down)");
  if (offset.norm() == 0)
    throw pg::UsageError("--offset is zero: the panoramas must be shot from different points");
  return offset;
}

// --max-memory: the run's estimate from the reference panorama's size (its header, or the camera's
// size), before either panorama is decoded.
void require_memory(const fs::path& reference, std::optional<cv::Size> size, const Options& o) {
  if (!size) size = pg::peek_image_size(reference);
  if (!size) return;  // a format whose header pg cannot read: decoding checks its size
  const std::uint64_t bytes = pg::sphere_depth_memory_bytes(
      *size, pg::decoded_image_bytes_per_pixel(reference), pg::max_flow_channels, o.depth);
  pg::cli::require_memory(bytes, pg::str("spherical depth of ", size->width, "x", size->height,
                                         " panoramas at scale ", o.depth.scale));
}

cv::Mat read_panorama(const fs::path& path) {
  cv::Mat image = pg::read_image(path);
  if (image.cols != 2 * image.rows)
    throw pg::InputError(path,
                         pg::str("is ", image.cols, "x", image.rows, ", not a 2:1 equirectangular panorama"));
  return image;
}

pg::Camera equirect_camera(const std::string& id, const cv::Mat& image) {
  pg::Camera camera;
  camera.id = id;
  camera.model = pg::CameraModel::equirectangular;
  camera.width = image.cols;
  camera.height = image.rows;
  return camera;
}

fs::path image_path(const fs::path& cameras_file, const pg::Camera& camera) {
  if (camera.image.empty()) throw pg::InputError(cameras_file, "camera '" + camera.id + "' names no image");
  const fs::path image = camera.image;
  return image.is_absolute() ? image : cameras_file.parent_path() / image;
}

// The pair from a cameras file: the named rig (or its only two-camera rig, or its first two cameras).
pg::SpherePair pair_from_cameras(pg::cli::Frame& frame, const Options& o, std::string& stem) {
  const pg::CameraSet set = pg::read_cameras(o.cameras);
  std::vector<std::string> ids;
  std::optional<Eigen::Vector3d> rig_offset;
  for (const pg::Rig& rig : set.rigs) {
    if ((o.rig.empty() && rig.camera_ids.size() == 2) || rig.id == o.rig) {
      ids = rig.camera_ids, rig_offset = rig.offset;
      break;
    }
  }
  if (!o.rig.empty() && ids.empty()) throw pg::InputError(o.cameras, "no rig '" + o.rig + "'");
  if (ids.empty()) {
    if (set.cameras.size() < 2) throw pg::InputError(o.cameras, "needs two panoramas (a two-camera rig)");
    ids = {set.cameras[0].id, set.cameras[1].id};
  }
  if (ids.size() != 2) throw pg::InputError(o.cameras, "rig '" + o.rig + "' does not have two cameras");
  const pg::Camera& reference = *set.find(ids[0]);
  const pg::Camera& other = *set.find(ids[1]);
  for (const pg::Camera* camera : {&reference, &other})
    if (camera->model != pg::CameraModel::equirectangular)
      throw pg::InputError(o.cameras, "camera '" + camera->id + "' is not equirectangular");
  const fs::path reference_path = image_path(o.cameras, reference), other_path = image_path(o.cameras, other);
  frame.input(reference_path);
  frame.input(other_path);
  require_memory(reference_path, cv::Size(reference.width, reference.height), o);
  pg::SpherePair pair;
  pair.reference = read_panorama(reference_path);
  pair.other = read_panorama(other_path);
  for (const auto& [camera, image, path] : {std::tuple{&reference, &pair.reference, &reference_path},
                                            std::tuple{&other, &pair.other, &other_path}})
    if (image->cols != camera->width || image->rows != camera->height)
      throw pg::InputError(*path, pg::str("is ", image->cols, "x", image->rows, " but camera '", camera->id,
                                          "' is ", camera->width, "x", camera->height));
  pair.reference_camera = reference;
  // The full relative pose from the two poses; the rig's nominal offset when the poses coincide.
  const pg::Rigid3 other_from_reference = other.cam_from_world * reference.cam_from_world.inverse();
  pair.baseline = reference.cam_from_world * other.cam_from_world.centre();
  pair.other_from_reference = other_from_reference.rotation_matrix();
  if (pair.baseline.norm() == 0 && rig_offset) pair.baseline = *rig_offset;
  if (pair.baseline.norm() == 0)
    throw pg::InputError(o.cameras, "cameras '" + ids[0] + "' and '" + ids[1] +
                                        "' share their centre and the rig gives no offset: no baseline");
  stem = reference.id;
  return pair;
}

pg::SpherePair pair_from_images(pg::cli::Frame& frame, const Options& o, std::string& stem) {
  if (o.reference.empty() || o.other.empty() || o.offset.empty())
    throw pg::UsageError("give --reference, --other and --offset, or --cameras");
  const Eigen::Vector3d offset = parse_offset(o.offset);
  frame.input(o.reference);
  frame.input(o.other);
  require_memory(o.reference, std::nullopt, o);
  pg::SpherePair pair;
  pair.reference = read_panorama(o.reference);
  pair.other = read_panorama(o.other);
  if (pair.other.size() != pair.reference.size())
    throw pg::InputError(o.other, pg::str("is ", pair.other.cols, "x", pair.other.rows, " but ", o.reference,
                                          " is ", pair.reference.cols, "x", pair.reference.rows));
  pair.reference_camera = equirect_camera(fs::path(o.reference).stem().string(), pair.reference);
  pair.baseline = offset;
  stem = fs::path(o.reference).stem().string();
  return pair;
}

}  // namespace

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-sphdepth", "range map and sphere-grid mesh from two equirectangular panoramas a baseline apart",
       "  pg-sphdepth --reference lower.exr --other upper.exr --offset 0,-0.27,0 --out-dir geo\n"
       "  pg-sphdepth --cameras pano/cameras.json --out-dir geo          # the two-camera rig\n"
       "  pg-sphdepth --reference down.png --other up.png --offset 0,-0.2,0 --scale 0.5 --out-dir geo"});
  Options o;
  CLI::App& app = frame.app();
  app.add_option("--reference", o.reference, "reference panorama (its ranges are computed; 8/16-bit or HDR)");
  app.add_option("--other", o.other, "second panorama, same size");
  app.add_option(
      "--offset", o.offset,
      "X,Y,Z: the other centre in the reference camera frame, metres (x right, y down, z forward); "
      "0,-0.27,0 = 27 cm above");
  app.add_option("--cameras", o.cameras, "cameras file with the two panoramas (a rig); replaces the above");
  app.add_option("--rig", o.rig, "rig id in --cameras (default: the two-camera rig)");
  app.add_option("--out-dir", o.out_dir, "folder for STEM.exr, STEM-mesh.ply and STEM-range.png")->required();
  app.add_option("--stem", o.stem, "output name stem (default: the reference's file stem or camera id)");
  app.add_option("--preset", o.preset, "flow settings: fast, balanced (default) or accurate");
  app.add_option("--alpha", o.alpha, "flow smoothness weight (default from the preset: 3)")
      ->check(pg::cli::positive());
  app.add_option("--scale", o.depth.scale, "resolution of the computation and outputs, in (0, 1]");
  app.add_option("--pole-band", o.depth.pole_band_deg, "degrees around the baseline axis left invalid (10)");
  app.add_option("--max-fb-error", o.depth.max_fb_error, "forward-backward limit, rectified pixels (0.5)");
  app.add_option("--max-range", o.depth.max_range, "ranges beyond this are invalid, metres (0 = no limit)");
  app.add_option("--max-range-jump", o.mesh.max_range_jump,
                 "mesh: no triangle whose ranges differ by more than this fraction (0.1)");
  app.add_option("--mesh-format", o.mesh_format, "ply (default) or obj");
  app.add_flag("--keep-all", o.depth.keep_all,
               "keep every triangulated range; rejections only zero the confidence");
  app.add_flag("--fill-occlusions", o.depth.fill_occlusions,
               "pixels failing the forward-backward check take their meridian's background range (half "
               "confidence) instead of being invalid");
  return frame.run(argc, argv, [&] {
    if (o.mesh_format != "ply" && o.mesh_format != "obj")
      throw pg::UsageError("--mesh-format must be ply or obj");
    o.depth.flow = pg::FlowOptions::preset(o.preset);
    // The panoramas' flow runs along meridians, in the epipolar mode, which has its own weight.
    if (o.alpha > 0) o.depth.flow.epipolar_alpha = o.alpha;
    o.depth.check();
    if (!o.cameras.empty() && (!o.reference.empty() || !o.other.empty() || !o.offset.empty()))
      throw pg::UsageError("--cameras replaces --reference, --other and --offset; give one or the other");
    if (!o.cameras.empty()) frame.input(o.cameras);
    frame.output_dir(o.out_dir);
    std::string stem;
    const pg::SpherePair pair =
        o.cameras.empty() ? pair_from_images(frame, o, stem) : pair_from_cameras(frame, o, stem);
    if (!o.stem.empty()) stem = o.stem;
    if (pair.reference.channels() != pair.other.channels())
      throw pg::UsageError("the panoramas differ in channel count");

    pg::SphereDepthResult result = pg::compute_sphere_depth(pair, o.depth);
    result.map.provenance = pg::Provenance::current();
    const fs::path out_dir = o.out_dir;
    const fs::path exr = out_dir / (stem + ".exr");
    const fs::path mesh_path = out_dir / (stem + "-mesh." + o.mesh_format);
    const fs::path preview = out_dir / (stem + "-range.png");
    for (const fs::path& path : {exr, mesh_path, preview}) frame.output(path);
    pg::write_depth_exr(exr, result.map);
    pg::write_depth_preview_png(preview, result.map);

    cv::Mat colors = pair.reference;
    if (colors.size() != result.map.depth.size())
      cv::resize(colors, colors, result.map.depth.size(), 0, 0, cv::INTER_AREA);
    if (colors.depth() == CV_16U) colors.convertTo(colors, CV_32F, 1.0 / 65535);
    pg::Mesh mesh = pg::sphere_grid_mesh(result.map, o.mesh, colors);
    mesh.provenance = pg::Provenance::current();
    pg::write_mesh(mesh_path, mesh);

    pg::RoomPlaneOptions plane_options;
    plane_options.baseline = pair.baseline;
    plane_options.seed = frame.seed();
    const pg::RoomPlanes planes = pg::fit_room_planes(result.map, plane_options);
    pg::log::info(pg::str(stem, ": ", result.valid, " valid pixels (", 100 * result.valid_fraction(), "%, ",
                          result.filled, " filled); rejected: pole band ", result.pole_band,
                          ", inconsistent ", result.inconsistent, ", untriangulated ", result.untriangulated,
                          ", too far ", result.too_far, "; mesh ", mesh.vertex_count(), " vertices, ",
                          mesh.face_count(), " triangles"));
    if (planes.floor)
      pg::log::info(pg::str("floor plane: ", planes.floor->offset, " m below the centre, fit rms ",
                            planes.floor->rms, " m over ", planes.floor->inliers, " points"));
    pg::RunReport& report = pg::RunReport::global();
    report.set_metric("width", result.map.depth.cols);
    report.set_metric("height", result.map.depth.rows);
    report.set_metric("baseline", pair.baseline.norm());
    report.set_metric("valid_fraction", result.valid_fraction());
    if (o.depth.fill_occlusions)
      report.set_metric("filled_fraction", double(result.filled) / result.map.depth.total());
    report.set_metric("rejected", {{"pole_band", result.pole_band},
                                   {"inconsistent", result.inconsistent},
                                   {"untriangulated", result.untriangulated},
                                   {"too_far", result.too_far}});
    report.set_metric("mesh", {{"vertices", mesh.vertex_count()}, {"triangles", mesh.face_count()}});
    report.set_metric("planes", planes.to_json());
    report.add_timing("flow", result.flow_seconds);
    report.add_timing("triangulation", result.triangulation_seconds);
  });
}
