// TsdfVolume::integrate(DepthFrame) on the OpenCL device (PoCL where there is no GPU) against the CPU
// path: the same frames give the same volume within float rounding, and frames the kernel does not
// cover (colour, non-pinhole cameras) take the CPU path bit for bit.
#include <gtest/gtest.h>

#include "pg/core/run_report.h"
#include "pg/fusion/fusion_test_scenes.h"
#include "pg/fusion/tsdf_volume.h"
#include "pg/gpu/test_support.h"

namespace pg::fusion {
namespace {

// Selects a device for the scope of a test and restores the automatic choice after it.
struct DeviceScope {
  explicit DeviceScope(gpu::DeviceKind kind) { gpu::set_requested_device(kind); }
  ~DeviceScope() { gpu::set_requested_device(gpu::DeviceKind::automatic); }
};

Mesh set_scene() {
  Mesh scene = testing::ground(2.0f);
  testing::append(scene, testing::box({0.3f, -0.6f, 0.0f}, {0.9f, 0.0f, 0.5f}));
  testing::append(scene, testing::sphere({-0.5f, 0.4f, 0.45f}, 0.45f));
  return scene;
}

// Exact depth frames of the scene; with_color adds a colour image per frame (a gradient).
std::vector<DepthFrame> frames_of(const std::vector<Camera>& cameras, bool with_color = false) {
  const TriangleBvh bvh(set_scene());
  std::vector<DepthFrame> frames;
  for (const Camera& camera : cameras) {
    cv::Mat3b color;
    if (with_color) {
      color.create(camera.height, camera.width);
      for (int y = 0; y < color.rows; ++y)
        for (int x = 0; x < color.cols; ++x) color(y, x) = cv::Vec3b(x % 256, y % 256, (x + y) % 256);
    }
    frames.push_back(make_depth_frame(testing::render_depth(bvh, camera), camera.id, {}, {}, color));
  }
  return frames;
}

TsdfVolume integrate_on(gpu::DeviceKind device, const std::vector<DepthFrame>& frames,
                        const TsdfOptions& options) {
  const DeviceScope scope(device);
  TsdfVolume volume(options);
  for (const DepthFrame& frame : frames) volume.integrate(frame);
  return volume;
}

std::uint64_t device_frames() {
  return RunReport::global().metrics().value("tsdf_device_frames", std::uint64_t(0));
}

TEST(TsdfDevice, PinholeFramesOnOpenClMatchTheCpu) {
  PG_REQUIRE_OPENCL();
  // Twelve overlapping views: every frame after the first averages into the values already there,
  // with per-pixel weights (centre falloff, angle) and the cos_angle band.
  const auto frames = frames_of(testing::orbit(12, 3.0, 1.8, {0, 0, 0.2}, 128, 96, 110));
  const TsdfOptions options{.voxel_size = 0.03};
  const TsdfVolume cpu = integrate_on(gpu::DeviceKind::cpu, frames, options);
  const std::uint64_t before = device_frames();
  const TsdfVolume opencl = integrate_on(gpu::DeviceKind::opencl, frames, options);
  EXPECT_EQ(device_frames() - before, frames.size());  // the device path ran, for every frame

  ASSERT_GT(cpu.active_voxel_count(), 100000u);
  EXPECT_EQ(opencl.active_voxel_count(), cpu.active_voxel_count());
  EXPECT_EQ(opencl.leaf_count(), cpu.leaf_count());
  const TsdfVolume::Difference difference = opencl.compare(cpu);  // infinite unless the active sets agree
  EXPECT_LT(difference.distance, 1e-5);
  EXPECT_LT(difference.weight_relative, 1e-5);
  const Mesh cpu_mesh = cpu.extract_mesh(), opencl_mesh = opencl.extract_mesh();
  ASSERT_GT(cpu_mesh.face_count(), 1000u);
  EXPECT_EQ(opencl_mesh.vertex_count(), cpu_mesh.vertex_count());
  EXPECT_EQ(opencl_mesh.face_count(), cpu_mesh.face_count());
}

TEST(TsdfDevice, CudaRequestUsesOpenClAndAddsToCpuIntegratedValues) {
  PG_REQUIRE_OPENCL();
  const auto frames = frames_of(testing::orbit(4, 3.0, 1.8, {0, 0, 0.2}, 96, 72, 85));
  const TsdfOptions options{.voxel_size = 0.04};
  const TsdfVolume cpu = integrate_on(gpu::DeviceKind::cpu, frames, options);
  // Half the frames on the CPU, the rest on the device (a CUDA request: no CUDA TSDF kernel, so
  // OpenCL where it is present), into the same volume.
  TsdfVolume mixed(options);
  {
    const DeviceScope scope(gpu::DeviceKind::cpu);
    for (std::size_t i = 0; i < frames.size() / 2; ++i) mixed.integrate(frames[i]);
  }
  const std::uint64_t before = device_frames();
  {
    const DeviceScope scope(gpu::DeviceKind::cuda);
    for (std::size_t i = frames.size() / 2; i < frames.size(); ++i) mixed.integrate(frames[i]);
  }
  EXPECT_EQ(device_frames() - before, frames.size() - frames.size() / 2);
  const TsdfVolume::Difference difference = mixed.compare(cpu);
  EXPECT_LT(difference.distance, 1e-5);
  EXPECT_LT(difference.weight_relative, 1e-5);
}

TEST(TsdfDevice, ColourAndPanoramaFramesStayOnTheCpuBitForBit) {
  PG_REQUIRE_OPENCL();
  auto frames = frames_of(testing::orbit(3, 3.0, 1.8, {0, 0, 0.2}, 96, 72, 85), true);
  Camera panorama;
  panorama.id = "panorama";
  panorama.model = CameraModel::equirectangular;
  panorama.width = 128, panorama.height = 64;
  panorama.cam_from_world = Rigid3::look_at({0.2, -1.2, 1.0}, {0, 0, 0.3});
  const auto more = frames_of({panorama});
  frames.push_back(more[0]);
  const TsdfOptions options{.voxel_size = 0.04, .color = true};
  const TsdfVolume cpu = integrate_on(gpu::DeviceKind::cpu, frames, options);
  const std::uint64_t before = device_frames();
  const TsdfVolume opencl = integrate_on(gpu::DeviceKind::opencl, frames, options);
  EXPECT_EQ(device_frames(), before);
  EXPECT_GT(cpu.active_voxel_count(), 10000u);
  const TsdfVolume::Difference difference = opencl.compare(cpu);
  EXPECT_EQ(difference.distance, 0.0);
  EXPECT_EQ(difference.weight_relative, 0.0);
}

}  // namespace
}  // namespace pg::fusion
