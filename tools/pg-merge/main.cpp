// pg-merge: one surface from depth maps, RGB-D frames, range scans (volumetric, Curless & Levoy on
// OpenVDB) and from oriented point clouds (Poisson). Farm jobs: `integrate` writes a partial .vdb
// from a range of inputs, `combine` sums partials into the result of a single run.
#include <chrono>
#include <iostream>
#include <optional>

#include "common/cli.h"
#include "pg/camera/size_check.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/run_report.h"
#include "pg/fusion/merge_inputs.h"
#include "pg/fusion/point_surface.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/point_cloud.h"

namespace fs = std::filesystem;
using namespace pg;
using namespace pg::fusion;

namespace {

struct InputOptions {
  std::vector<std::string> depth, scans;
  std::string masks_dir, images_dir;
  std::string rgbd_cameras, rgbd_poses, rgbd_depth = "depth/{id}.png", rgbd_color;
  std::vector<double> rgbd_intrinsics, sensor_origin, sensor_direction;
  std::vector<int> rgbd_size{640, 480};
  std::string scan_conf;
  int range_start = 0, range_size = 0;
  InputSettings settings;
};

struct VolumeOptions {
  double voxel_size = 0, truncation = 0;
};

struct OutputOptions {
  std::string out, vdb;
  ExtractOptions extract;
};

// "path@2.5" -> (path, 2.5); "path" -> (path, 1).
std::pair<fs::path, double> split_weight(const std::string& spec) {
  const auto at = spec.rfind('@');
  if (at == std::string::npos) return {spec, 1.0};
  try {
    std::size_t used = 0;
    const double weight = std::stod(spec.substr(at + 1), &used);
    if (used != spec.size() - at - 1 || !(weight > 0)) throw std::invalid_argument("");
    return {spec.substr(0, at), weight};
  } catch (const std::logic_error&) {
    throw UsageError(str("'", spec, "': the weight after '@' must be a positive number"));
  }
}

Eigen::Vector3d vector3(const std::vector<double>& v) {
  return {v[0], v[1], v[2]};
}

// The colour image of a depth EXR in --images: the camera's image file name, else <stem>.png/.jpg.
fs::path color_for(const fs::path& images_dir, const fs::path& depth_path, const Camera& camera) {
  std::vector<fs::path> candidates;
  if (!camera.image.empty()) candidates.push_back(images_dir / fs::path(camera.image).filename());
  for (const char* ext : {".png", ".jpg", ".jpeg", ".exr"})
    candidates.push_back(images_dir / (depth_path.stem().string() + ext));
  for (const auto& c : candidates)
    if (fs::exists(c)) return c;
  throw InputError(depth_path, str("no colour image for it in ", images_dir.string(), " (looked for ",
                                   candidates.front().filename().string(), ")"));
}

// The user mask <name>.png in masks_dir, if there is one, checked against `camera`'s size from its
// header, so that a wrong mask fails before any input is integrated.
fs::path checked_mask(const std::string& masks_dir, const std::string& name, const fs::path& depth,
                      const Camera& camera) {
  if (masks_dir.empty()) return {};
  const fs::path mask = fs::path(masks_dir) / (name + ".png");
  if (!fs::exists(mask)) return {};
  if (const std::optional<cv::Size> size = peek_image_size(mask))
    require_mask_size(mask, *size, depth, {camera.width, camera.height});
  return mask;
}

// Every input named by the options, in order (depth maps, RGB-D frames, scans), from the command
// line and the camera, pose and placement lists; its files are not opened yet.
std::vector<MergeInput> all_inputs(cli::Frame& frame, const InputOptions& o) {
  std::vector<MergeInput> inputs;
  for (const auto& spec : o.depth) {
    auto [path, weight] = split_weight(spec);
    MergeInput& in = inputs.emplace_back();
    in.kind = InputKind::depth_exr;
    in.path = path;
    in.multiplier = weight;
  }
  if (!o.rgbd_cameras.empty() || !o.rgbd_poses.empty()) {
    CameraSet cameras;
    if (!o.rgbd_cameras.empty()) {
      frame.input(o.rgbd_cameras);
      cameras = read_cameras(o.rgbd_cameras);
    } else {
      frame.input(o.rgbd_poses);
      if (o.rgbd_intrinsics.size() != 4) throw UsageError("--rgbd-poses needs --rgbd-intrinsics fx,fy,cx,cy");
      cameras = cameras_from_pose_list(
          o.rgbd_poses,
          {o.rgbd_intrinsics[0], o.rgbd_intrinsics[1], o.rgbd_intrinsics[2], o.rgbd_intrinsics[3]},
          o.rgbd_size[0], o.rgbd_size[1]);
    }
    for (const Camera& camera : cameras.cameras) {
      MergeInput& in = inputs.emplace_back();
      in.kind = InputKind::rgbd;
      in.path = expand_pattern(o.rgbd_depth, camera.id);
      in.camera = camera;
      if (!o.rgbd_color.empty()) in.color = expand_pattern(o.rgbd_color, camera.id);
    }
  }
  if (!o.scans.empty() || !o.scan_conf.empty()) {
    if (!o.sensor_origin.empty() && !o.sensor_direction.empty())
      throw UsageError("scans take one of --sensor-origin or --sensor-direction, not both");
    auto scan_input = [&](const fs::path& path, const Rigid3& placement, double weight) {
      MergeInput& in = inputs.emplace_back();
      in.kind = InputKind::scan;
      in.path = path;
      in.world_from_scan = placement;
      in.multiplier = weight;
      if (!o.sensor_origin.empty()) in.sensor_origin = vector3(o.sensor_origin);
      if (!o.sensor_direction.empty()) in.sensor_direction = vector3(o.sensor_direction);
    };
    for (const auto& spec : o.scans) {
      auto [path, weight] = split_weight(spec);
      scan_input(path, Rigid3{}, weight);
    }
    if (!o.scan_conf.empty()) {
      frame.input(o.scan_conf);
      for (const ScanPlacement& p : read_stanford_conf(o.scan_conf))
        scan_input(p.file, p.world_from_scan, 1.0);
    }
  }
  if (inputs.empty())
    throw UsageError("no inputs: give --depth, --rgbd-cameras/--rgbd-poses, --scan or --scan-conf");
  return inputs;
}

// Checks one input's files from their headers, and finds its mask (and a depth map's colour image),
// so that a wrong file fails before any input is integrated. Formats without a header pg can peek
// are checked when decoded.
void check_input(cli::Frame& frame, MergeInput& in, const InputOptions& o) {
  frame.input(in.path);
  switch (in.kind) {
    case InputKind::depth_exr: {
      const Camera camera = read_depth_exr_header(in.path).camera;
      in.mask = checked_mask(o.masks_dir, in.path.stem().string(), in.path, camera);
      if (!o.images_dir.empty()) in.color = color_for(o.images_dir, in.path, camera);
      break;
    }
    case InputKind::rgbd:
      if (const std::optional<cv::Size> size = peek_image_size(in.path))
        require_camera_size(in.path, size->width, size->height, in.camera, "depth image");
      in.mask = checked_mask(o.masks_dir, in.camera.id, in.path, in.camera);
      break;
    case InputKind::scan:
      // Only point clouds whose points carry their own sensor origins need no sensor option.
      if (!inspect_scan(in.path).per_point_origins && !in.sensor_origin && !in.sensor_direction)
        throw UsageError(str(in.path.string(),
                             ": scans need --sensor-origin x,y,z or --sensor-direction x,y,z (in each scan's "
                             "frame), unless its points carry sensor_x, sensor_y, sensor_z"));
      break;
  }
  // Every file read is an input: in the report and provenance, and never overwritten.
  for (const fs::path& file : {in.color, in.mask})
    if (!file.empty()) frame.input(file);
}

// The inputs of this job: those in --range-start/--range-size (a farm split), each checked. The
// others are not read, but no output may overwrite them.
std::vector<MergeInput> list_inputs(cli::Frame& frame, const InputOptions& o) {
  for (const std::string& folder : {o.masks_dir, o.images_dir})
    if (!folder.empty()) frame.input_dir(folder);  // a mistyped folder fails rather than reads nothing
  std::vector<MergeInput> inputs = all_inputs(frame, o);
  for (const MergeInput& in : inputs) {
    frame.keep(in.path);
    if (!in.color.empty()) frame.keep(in.color);
  }
  if (o.range_start > 0 || o.range_size > 0) {
    if (std::size_t(o.range_start) >= inputs.size())
      throw UsageError(str("--range-start ", o.range_start, " is beyond the ", inputs.size(), " inputs"));
    const std::size_t end =
        o.range_size > 0 ? std::min(inputs.size(), std::size_t(o.range_start + o.range_size)) : inputs.size();
    inputs = std::vector<MergeInput>(inputs.begin() + o.range_start, inputs.begin() + end);
  }
  for (MergeInput& in : inputs) check_input(frame, in, o);
  return inputs;
}

TsdfVolume make_volume(const VolumeOptions& v, bool color) {
  return TsdfVolume({.voxel_size = v.voxel_size,
                     .truncation = v.truncation,
                     .max_memory = cli::memory_budget(),
                     .color = color});
}

void integrate_all(TsdfVolume& volume, const std::vector<MergeInput>& inputs, const InputSettings& settings) {
  ScopedTimer timer("integrate");
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    integrate_input(volume, inputs[i], settings);
    log::info("integrated ", i + 1, "/", inputs.size(), " ", inputs[i].path.filename().string(), ": ",
              volume.leaf_count(), " leaves, ", volume.memory_bytes() >> 20, " MiB");
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RunReport::global().set_metric("inputs", inputs.size());
  RunReport::global().set_metric("integration_seconds_per_input", seconds / double(inputs.size()));
}

void finish(const TsdfVolume& volume, const OutputOptions& out) {
  auto& report = RunReport::global();
  report.set_metric("voxel_size", volume.voxel_size());
  report.set_metric("truncation", volume.truncation());
  report.set_metric("active_voxels", volume.active_voxel_count());
  report.set_metric("grid_bytes", volume.memory_bytes());
  if (!out.vdb.empty()) volume.write_vdb(out.vdb, Provenance::current());
  if (out.out.empty()) return;
  Mesh mesh;
  {
    ScopedTimer timer("extract");
    mesh = volume.extract_mesh(out.extract);
  }
  if (mesh.faces.empty())
    throw FailedError("the merged volume holds no surface (inputs do not overlap a zero crossing)");
  report.set_metric("vertices", mesh.vertex_count());
  report.set_metric("faces", mesh.face_count());
  mesh.provenance = Provenance::current();
  write_mesh(out.out, mesh);
  log::info("wrote ", out.out, ": ", mesh.vertex_count(), " vertices, ", mesh.face_count(), " faces");
}

void add_input_options(CLI::App& c, InputOptions& o) {
  c.add_option("--depth", o.depth,
               "pg depth EXRs (pg-depth z-depth, pg-sphdepth range); FILE@W weighs one by W")
      ->expected(1, -1);
  c.add_option("--masks", o.masks_dir,
               "folder of user masks <depth stem>.png or <camera id>.png, nonzero = ignore");
  c.add_option("--images", o.images_dir, "folder of colour images for the depth EXRs (per-vertex colour)");
  c.add_option("--rgbd-cameras", o.rgbd_cameras, "RGB-D frames: a cameras.json, one camera per frame");
  c.add_option("--rgbd-poses", o.rgbd_poses,
               "RGB-D frames: a pose list 'tx ty tz qx qy qz qw' (camera to world)");
  c.add_option("--rgbd-intrinsics", o.rgbd_intrinsics, "fx,fy,cx,cy for --rgbd-poses")
      ->delimiter(',')
      ->expected(4);
  c.add_option("--rgbd-size", o.rgbd_size, "width,height for --rgbd-poses")
      ->delimiter(',')
      ->expected(2)
      ->capture_default_str();
  c.add_option("--rgbd-depth", o.rgbd_depth, "depth image path pattern, {id} = camera id (16-bit PNG/PGM)")
      ->capture_default_str();
  c.add_option("--rgbd-color", o.rgbd_color, "colour image path pattern, {id} = camera id");
  c.add_option("--depth-scale", o.settings.depth_scale,
               "scene units per RGB-D depth unit (0.001: millimetres to metres)")
      ->capture_default_str();
  c.add_option("--scan", o.scans,
               "range scans (PLY/OBJ meshes, Stanford range grids, or PLY point clouds integrated along "
               "each point's sensor ray); FILE@W weighs one by W")
      ->expected(1, -1);
  c.add_option("--scan-conf", o.scan_conf, "Stanford .conf alignment file listing scans (bmesh lines)");
  c.add_option("--sensor-origin", o.sensor_origin,
               "scans: sensor centre x,y,z in each scan's frame (point clouds may carry sensor_x/y/z)")
      ->delimiter(',')
      ->expected(3);
  c.add_option("--sensor-direction", o.sensor_direction,
               "scans: parallel ray direction x,y,z in each scan's frame")
      ->delimiter(',')
      ->expected(3);
  c.add_option("--range-start", o.range_start, "first input of this job (farm split)")
      ->check(pg::cli::non_negative());
  c.add_option("--range-size", o.range_size, "inputs in this job (0 = to the end)")
      ->check(pg::cli::non_negative());
  WeightOptions& w = o.settings.weights;
  c.add_option("--centre-falloff", w.centre_falloff, "weight 1 - f (r/r_corner)^2 towards the image corners")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  c.add_flag("!--no-angle-weight", w.use_angle, "do not weigh by cos(normal, ray)");
  c.add_option("--min-cos", w.min_cos, "drop samples more grazing than this cos(normal, ray)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  c.add_flag("!--no-confidence", w.use_confidence, "ignore the depth maps' confidence channel");
  c.add_flag("!--no-quality", w.use_quality, "ignore the cameras' tracking quality");
  c.add_option("--max-depth", w.max_depth, "drop samples farther than this (0 = no limit)")
      ->check(pg::cli::non_negative());
}

void add_volume_options(CLI::App& c, VolumeOptions& v) {
  c.add_option("--voxel-size", v.voxel_size, "voxel edge in scene units")
      ->required()
      ->check(pg::cli::positive());
  c.add_option("--truncation", v.truncation,
               "half-width of the distance band, 1 to 256 voxels (default 4 voxels)")
      ->check(pg::cli::non_negative());
}

void add_output_options(CLI::App& c, OutputOptions& o, bool vdb_required) {
  auto* out = c.add_option("--out", o.out, "merged mesh (PLY or OBJ)");
  auto* vdb = c.add_option("--vdb", o.vdb, "also write the grids as .vdb (opens in Houdini)");
  if (vdb_required) vdb->required();
  if (!vdb_required) out->required();
  c.add_option("--min-weight", o.extract.min_weight, "drop vertices with less accumulated weight")
      ->check(pg::cli::non_negative());
  c.add_option("--min-piece", o.extract.min_component_fraction,
               "remove pieces smaller than this fraction of the largest piece's faces")
      ->check(CLI::Range(0.0, 1.0));
  c.add_option("--min-piece-faces", o.extract.min_component_faces, "remove pieces with fewer faces");
}

}  // namespace

int main(int argc, char** argv) {
  cli::Frame frame(
      {"pg-merge", "merge depth maps, RGB-D frames, scans or point clouds into one mesh",
       "  pg-merge volume --depth shot/depth/*.exr --images shot/images --voxel-size 0.02 --out merged.ply "
       "--vdb merged.vdb\n"
       "  pg-merge volume --rgbd-poses pose.txt --rgbd-intrinsics 518,519,325.5,253.5 --rgbd-depth "
       "'depth/{id}.pgm' \\\n"
       "      --rgbd-color 'color/{id}.png' --voxel-size 0.01 --max-depth 3 --out room.ply\n"
       "  pg-merge volume --scan-conf bunny/data/bun.conf --sensor-direction 0,0,-1 --voxel-size 0.0005 "
       "--out bunny.ply\n"
       "  pg-merge volume --scan sweep.ply --sensor-origin 0,0,1.8 --voxel-size 0.02 --out room.ply\n"
       "  pg-merge integrate --depth d/*.exr --range-start 0 --range-size 50 --voxel-size 0.02 --vdb "
       "part0.vdb\n"
       "  pg-merge combine --partials part*.vdb --out merged.ply --vdb merged.vdb\n"
       "  pg-merge points --points sparse.ply --cameras cameras.json --voxel-size 0.02 --out surface.ply"});
  CLI::App& app = frame.app();
  app.require_subcommand(1);
  app.fallthrough();

  InputOptions volume_inputs, integrate_inputs;
  VolumeOptions volume_grid, integrate_grid;
  OutputOptions volume_out, combine_out;
  CLI::App* volume =
      app.add_subcommand("volume", "merge all inputs into a mesh (Curless & Levoy TSDF on OpenVDB)");
  add_input_options(*volume, volume_inputs);
  add_volume_options(*volume, volume_grid);
  add_output_options(*volume, volume_out, false);

  CLI::App* integrate = app.add_subcommand("integrate", "integrate a range of inputs into a partial .vdb");
  add_input_options(*integrate, integrate_inputs);
  add_volume_options(*integrate, integrate_grid);
  std::string partial_out;
  integrate->add_option("--vdb", partial_out, "the partial volume")->required();

  std::vector<std::string> partials;
  CLI::App* combine = app.add_subcommand("combine", "sum partial volumes into the single-run result");
  combine->add_option("--partials", partials, "partial .vdb files from pg-merge integrate")
      ->required()
      ->expected(1, -1);
  add_output_options(*combine, combine_out, false);
  combine->get_option("--out")->required(false);

  std::string points_path, points_cameras, points_out, base_surface;
  PointSurfaceOptions point_options;
  CLI::App* points =
      app.add_subcommand("points", "surface from a point cloud: Hoppe normals, MST orientation, Poisson");
  points->add_option("--points", points_path, "point cloud PLY (normals are estimated when absent)")
      ->required();
  points->add_option("--cameras", points_cameras,
                     "cameras.json: normals are turned to face the cameras that see them");
  points->add_option("--voxel-size", point_options.voxel_size, "Poisson grid spacing in scene units")
      ->required()
      ->check(pg::cli::positive());
  points->add_option("--neighbours", point_options.neighbours, "k nearest neighbours for normals")
      ->capture_default_str();
  points
      ->add_option("--trim", point_options.trim_density,
                   "drop vertices where the point density is below this fraction of the median")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  points->add_option("--base-surface", base_surface,
                     "mesh filling where no points are (sampled at low weight)");
  points->add_option("--out", points_out, "surface mesh")->required();

  return frame.run(argc, argv, [&] {
    if (volume->parsed() || integrate->parsed()) {
      const bool whole = volume->parsed();
      InputOptions& o = whole ? volume_inputs : integrate_inputs;
      const auto inputs = list_inputs(frame, o);
      bool color = false;
      for (const auto& in : inputs)
        color |= !in.color.empty() || (in.kind == InputKind::scan && inspect_scan(in.path).has_color);
      if (whole) {
        if (!volume_out.out.empty()) frame.output(volume_out.out);
        if (!volume_out.vdb.empty()) frame.output(volume_out.vdb);
      } else {
        frame.output(partial_out);
      }
      TsdfVolume tsdf = make_volume(whole ? volume_grid : integrate_grid, color);
      integrate_all(tsdf, inputs, o.settings);
      if (whole) {
        finish(tsdf, volume_out);
      } else {
        tsdf.write_vdb(partial_out, Provenance::current());
        RunReport::global().set_metric("active_voxels", tsdf.active_voxel_count());
      }
    } else if (combine->parsed()) {
      if (combine_out.out.empty() && combine_out.vdb.empty())
        throw UsageError("combine needs --out and/or --vdb");
      for (const auto& p : partials) frame.input(p);
      if (!combine_out.out.empty()) frame.output(combine_out.out);
      if (!combine_out.vdb.empty()) frame.output(combine_out.vdb);
      // Colour when any partial has it, whatever their order (a chunk of scans without colour
      // may come first).
      const bool color = std::any_of(partials.begin(), partials.end(),
                                     [](const std::string& p) { return TsdfVolume::vdb_has_color(p); });
      std::optional<TsdfVolume> total;
      for (const auto& p : partials) {
        TsdfVolume part = TsdfVolume::read_vdb(p);
        if (!total) {
          total.emplace(TsdfVolume({.voxel_size = part.voxel_size(),
                                    .truncation = part.truncation(),
                                    .max_memory = cli::memory_budget(),
                                    .color = color}));
        }
        try {
          total->merge_partial(part);
        } catch (const UsageError& e) {
          throw InputError(p, e.what());
        }
      }
      finish(*total, combine_out);
    } else if (points->parsed()) {
      frame.input(points_path);
      if (!points_cameras.empty()) frame.input(points_cameras);
      if (!base_surface.empty()) frame.input(base_surface);
      frame.output(points_out);
      const PointCloud cloud = read_point_cloud_ply(points_path);
      std::optional<CameraSet> cameras;
      if (!points_cameras.empty()) cameras = read_cameras(points_cameras);
      std::optional<Mesh> base;
      if (!base_surface.empty()) base = read_mesh(base_surface);
      Mesh mesh =
          surface_from_points(cloud, cameras ? &*cameras : nullptr, base ? &*base : nullptr, point_options);
      RunReport::global().set_metric("vertices", mesh.vertex_count());
      RunReport::global().set_metric("faces", mesh.face_count());
      if (mesh.face_count() == 0) throw FailedError(str("no surface from the points of ", points_path));
      mesh.provenance = Provenance::current();
      write_mesh(points_out, mesh);
    }
  });
}
