// pg-merge's TSDF against Open3D's ScalableTSDFVolume (Debian python3-open3d, bench_merge_open3d.py)
// on the same RGB-D frames, voxel size and truncation, in one run:
//   - the 5 real Kinect frames (640x480) at 10 mm and 4 mm voxels;
//   - 8 RGB-D frames rendered exactly from the Stanford bunny reference at 2 mm and 1 mm voxels.
// Each merge runs in its own process (this binary with --pg, or the Python script), so the peak
// memory is the merge's own; both read one frame at a time, as pg-merge does. Prints integration ms
// per frame, extraction seconds, peak memory, the meshes' distance to each other, the fraction of
// depth pixels within 2 voxels of each mesh, and the accuracy and completeness of both against the
// bunny reference.
//
// Usage: bench_merge [DATA_DIR] [kinect|bunny]   (the second argument runs that set alone)
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "pg/eval/mesh_eval.h"
#include "pg/fusion/depth_agreement.h"
#include "pg/fusion/tsdf_volume.h"
#include "pg/gpu/device.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"

namespace fs = std::filesystem;
using namespace pg;
using namespace pg::fusion;

extern char** environ;

namespace {

struct Dataset {
  std::string name;
  fs::path poses;
  Intrinsics intrinsics;
  std::string depth_pattern, color_pattern;
  double depth_scale = 0.001;  // metres per depth unit
  double max_depth = 3.0;
  std::optional<fs::path> reference;
};

// Peak resident memory of this process image (VmHWM): unlike getrusage's maxrss it is not inherited
// from the parent across fork and exec.
double peak_resident_bytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  double kilobytes = 0;
  while (status >> key) {
    if (key == "VmHWM:") {
      status >> kilobytes;
      break;
    }
    status.ignore(1 << 20, '\n');
  }
  return kilobytes * 1024;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

DepthFrame load_frame(const Dataset& d, const Camera& camera) {
  const DepthMap map = read_rgbd_depth(expand_pattern(d.depth_pattern, camera.id), camera, d.depth_scale);
  const cv::Mat color = d.color_pattern.empty()
                            ? cv::Mat()
                            : cv::Mat(read_color_image(expand_pattern(d.color_pattern, camera.id)));
  return make_depth_frame(map, camera.id, {.max_depth = d.max_depth}, {}, color);
}

std::vector<DepthFrame> load_frames(const Dataset& d) {
  std::vector<DepthFrame> frames;
  for (const Camera& camera : cameras_from_pose_list(d.poses, d.intrinsics, 640, 480).cameras)
    frames.push_back(load_frame(d, camera));
  return frames;
}

// The child: one pg merge, timed like the Open3D script: frames one at a time, as pg-merge reads its
// inputs (read, not timed; integrated, timed; dropped).
int run_pg(const Dataset& d, double voxel, const fs::path& out) {
  // CPU against CPU: "auto" would first load the OpenCL driver to look for a GPU (PoCL here: its
  // start-up in the first frame's time, its memory pools in the peak).
  pg::gpu::set_requested_device(pg::gpu::DeviceKind::cpu);
  TsdfVolume volume({.voxel_size = voxel, .truncation = 4 * voxel, .color = !d.color_pattern.empty()});
  double integrate = 0;
  const std::vector<Camera> cameras = cameras_from_pose_list(d.poses, d.intrinsics, 640, 480).cameras;
  for (const Camera& camera : cameras) {
    const DepthFrame frame = load_frame(d, camera);
    const auto start = std::chrono::steady_clock::now();
    volume.integrate(frame);
    integrate += seconds_since(start);
  }
  const auto start = std::chrono::steady_clock::now();
  const Mesh mesh = volume.extract_mesh();
  const double extract = seconds_since(start);
  write_mesh(out, mesh);
  std::cout << nlohmann::json{{"integrate_ms_per_frame", 1000 * integrate / double(cameras.size())},
                              {"extract_seconds", extract},
                              {"peak_bytes", peak_resident_bytes()},
                              {"vertices", mesh.vertex_count()},
                              {"faces", mesh.face_count()}}
                   .dump()
            << "\n";
  return 0;
}

// Runs a command, returns the last line of its standard output parsed as JSON.
nlohmann::json run_json(const std::vector<std::string>& command, const fs::path& capture) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, capture.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv;
  for (const auto& c : command) argv.push_back(const_cast<char*>(c.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0)
    throw std::runtime_error("cannot run " + command[0]);
  posix_spawn_file_actions_destroy(&actions);
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream in(capture);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || last.empty())
    throw std::runtime_error(command[0] + " failed: " + last);
  return nlohmann::json::parse(last);
}

// 8 exact RGB-D frames of the bunny reference (depth in 0.1 mm units) from a ring 0.35 m away.
Dataset render_bunny(const fs::path& reference, const fs::path& folder) {
  const Mesh bunny = read_mesh(reference);
  const TriangleBvh bvh(bunny);
  const Eigen::Vector3d centre = bunny.bounds().center().cast<double>();
  const Intrinsics intrinsics{525, 525, 319.5, 239.5};
  fs::create_directories(folder);
  std::ofstream poses(folder / "pose.txt");
  for (int i = 0; i < 8; ++i) {
    const double angle = 2 * M_PI * i / 8;
    const Eigen::Vector3d eye =
        centre + Eigen::Vector3d(0.35 * std::cos(angle), 0.12 * (i % 2 ? 1 : -0.5), 0.35 * std::sin(angle));
    const Rigid3 world_from_cam = Rigid3::look_at(eye, centre, Eigen::Vector3d::UnitY()).inverse();
    cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(0));
    for (int y = 0; y < 480; ++y)
      for (int x = 0; x < 640; ++x) {
        const Eigen::Vector3d ray((x - intrinsics.cx) / intrinsics.fx, (y - intrinsics.cy) / intrinsics.fy,
                                  1.0);
        const auto hit = bvh.intersect(world_from_cam.translation.cast<float>(),
                                       (world_from_cam.rotation * ray).cast<float>());
        if (hit.hit)
          depth.at<std::uint16_t>(y, x) = std::uint16_t(std::lround(hit.t * 10000.0));  // z, 0.1 mm
      }
    write_image(folder / (std::to_string(i + 1) + ".png"), depth);
    const Eigen::Quaterniond q = world_from_cam.rotation;
    poses << world_from_cam.translation.transpose() << " " << q.x() << " " << q.y() << " " << q.z() << " "
          << q.w() << "\n";
  }
  return {"bunny (8 rendered frames)",
          folder / "pose.txt",
          intrinsics,
          (folder / "{id}.png").string(),
          "",
          1e-4,
          3.0,
          reference};
}

DepthAgreement agreement(const Mesh& mesh, const std::vector<DepthFrame>& frames, double tolerance) {
  const TriangleBvh bvh(mesh);
  DepthAgreement sum;
  for (const auto& f : frames) sum += depth_agreement(bvh, f, tolerance);
  return sum;
}

void compare(const Dataset& d, double voxel, const fs::path& work, const std::string& self,
             const fs::path& script) {
  const fs::path pg_mesh = work / "pg.ply", o3d_mesh = work / "open3d.ply";
  const std::string voxel_text = std::to_string(voxel);
  const auto ours = run_json(
      {self, "--pg", d.poses.string(), d.depth_pattern, d.color_pattern.empty() ? "-" : d.color_pattern,
       std::to_string(d.depth_scale), voxel_text, pg_mesh.string(), std::to_string(d.intrinsics.fx),
       std::to_string(d.intrinsics.fy), std::to_string(d.intrinsics.cx), std::to_string(d.intrinsics.cy)},
      work / "pg.json");
  std::vector<std::string> python{"/usr/bin/python3",
                                  script.string(),
                                  "--poses",
                                  d.poses.string(),
                                  "--intrinsics",
                                  std::to_string(d.intrinsics.fx),
                                  std::to_string(d.intrinsics.fy),
                                  std::to_string(d.intrinsics.cx),
                                  std::to_string(d.intrinsics.cy),
                                  "--depth",
                                  d.depth_pattern,
                                  "--depth-scale",
                                  std::to_string(1.0 / d.depth_scale),
                                  "--max-depth",
                                  std::to_string(d.max_depth),
                                  "--voxel",
                                  voxel_text,
                                  "--truncation",
                                  std::to_string(4 * voxel),
                                  "--out",
                                  o3d_mesh.string()};
  if (!d.color_pattern.empty()) python.insert(python.end(), {"--color", d.color_pattern});
  const auto theirs = run_json(python, work / "open3d.json");

  const Mesh a = read_mesh(pg_mesh), b = read_mesh(o3d_mesh);
  const MeshEvalOptions options{.samples = 200000, .thresholds = {voxel}};
  const MeshEvalResult between = evaluate_mesh(a, b, options);
  const auto frames = load_frames(d);
  std::cout << "\n== " << d.name << ", voxel " << voxel * 1000 << " mm, truncation " << 4 * voxel * 1000
            << " mm\n";
  // Pixels that disagree are split into those where the mesh is in front and those it misses.
  auto row = [](const char* name, const nlohmann::json& j, const DepthAgreement& a) {
    const double percent = 100.0 / double(std::max<std::size_t>(a.valid_pixels, 1));
    std::printf(
        "%-8s integrate %7.1f ms/frame   extract %6.3f s   peak %7.1f MB   %8d faces   %5.1f%% pixels within "
        "2 voxels (%4.1f%% in front, %4.1f%% missed)\n",
        name, j["integrate_ms_per_frame"].get<double>(), j["extract_seconds"].get<double>(),
        j["peak_bytes"].get<double>() / 1e6, j["faces"].get<int>(), percent * double(a.agreeing),
        percent * double(a.in_front), percent * double(a.missed));
  };
  row("pg", ours, agreement(a, frames, 2 * voxel));
  row("Open3D", theirs, agreement(b, frames, 2 * voxel));
  std::printf("ratio    Open3D/pg: integrate %.2fx, extract %.2fx, memory %.2fx\n",
              theirs["integrate_ms_per_frame"].get<double>() / ours["integrate_ms_per_frame"].get<double>(),
              theirs["extract_seconds"].get<double>() / ours["extract_seconds"].get<double>(),
              theirs["peak_bytes"].get<double>() / ours["peak_bytes"].get<double>());
  std::printf(
      "pg vs Open3D mesh: pg->Open3D p90 %.2f mm, Open3D->pg p90 %.2f mm, within one voxel %.1f%% / %.1f%%\n",
      between.accuracy.p90 * 1000, between.completeness.p90 * 1000, 100 * between.precision[0],
      100 * between.recall[0]);
  if (d.reference) {
    const Mesh reference = read_mesh(*d.reference);
    for (const auto& [name, mesh] : {std::pair<const char*, const Mesh*>{"pg", &a}, {"Open3D", &b}}) {
      const MeshEvalResult e = evaluate_mesh(*mesh, reference, options);
      std::printf(
          "%-8s vs bunny reference: accuracy mean %.3f p90 %.3f mm, completeness mean %.3f p90 %.3f mm\n",
          name, e.accuracy.mean * 1000, e.accuracy.p90 * 1000, e.completeness.mean * 1000,
          e.completeness.p90 * 1000);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--pg") {
    if (argc != 12) {
      std::cerr << "bench_merge --pg poses depth_pattern color_pattern|- metres_per_unit voxel out.ply fx fy "
                   "cx cy\n";
      return 2;
    }
    Dataset d{"child",
              argv[2],
              {std::stod(argv[8]), std::stod(argv[9]), std::stod(argv[10]), std::stod(argv[11])},
              argv[3],
              std::string(argv[4]) == "-" ? "" : argv[4],
              std::stod(argv[5]),
              3.0,
              std::nullopt};
    return run_pg(d, std::stod(argv[6]), argv[7]);
  }
  const fs::path data = argc > 1 ? fs::path(argv[1]) : fs::path(PG_SOURCE_DIR) / "../shared/data";
  const std::string only = argc > 2 ? argv[2] : "";  // "kinect" or "bunny": that set alone
  const fs::path script = fs::path(PG_SOURCE_DIR) / "bench/bench_merge_open3d.py";
  const fs::path work = fs::temp_directory_path() / ("pg-bench-merge-" + std::to_string(getpid()));
  fs::create_directories(work);
  const std::string self = fs::canonical("/proc/self/exe").string();
  try {
    const fs::path kinect = data / "rgbd/kinect-5frames";
    const Dataset kinect_set{"Kinect, 5 real frames 640x480",
                             kinect / "pose.txt",
                             {518, 519, 325.5, 253.5},
                             (kinect / "depth/{id}.pgm").string(),
                             (kinect / "color/{id}.png").string(),
                             0.001,
                             3.0,
                             std::nullopt};
    if (only != "bunny")
      for (double voxel : {0.01, 0.004}) compare(kinect_set, voxel, work, self, script);
    if (only != "kinect") {
      const Dataset bunny =
          render_bunny(data / "meshes/stanford-bunny/reconstruction/bun_zipper.ply", work / "bunny");
      for (double voxel : {0.002, 0.001}) compare(bunny, voxel, work, self, script);
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_merge: " << e.what() << "\n";
    fs::remove_all(work);
    return 1;
  }
  fs::remove_all(work);
  return 0;
}
