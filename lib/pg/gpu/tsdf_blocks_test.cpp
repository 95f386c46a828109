#include "pg/gpu/tsdf_blocks.h"

#include <gtest/gtest.h>

#include <cmath>

#include "pg/fusion/tsdf_volume.h"
#include "pg/gpu/test_support.h"

namespace pg::gpu {
namespace {

Camera pinhole(int width, int height, const Eigen::Vector3d& centre) {
  Camera c;
  c.id = "view";
  c.width = width;
  c.height = height;
  c.intrinsics = {0.9 * width, 0.9 * width, (width - 1) / 2.0, (height - 1) / 2.0};
  c.cam_from_world.rotation = Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.3, 1, 0.2).normalized());
  c.cam_from_world.translation = -(c.cam_from_world.rotation * centre);
  return c;
}

// A sphere of radius 0.5 at the origin seen from `centre`: depth z per pixel, NaN off the sphere.
fusion::DepthFrame sphere_frame(const Camera& camera) {
  fusion::DepthFrame frame;
  frame.name = "sphere";
  frame.camera = camera;
  frame.depth = cv::Mat1f(camera.height, camera.width, std::numeric_limits<float>::quiet_NaN());
  frame.weight = cv::Mat1f(camera.height, camera.width, 0.f);
  const Rigid3 world_from_cam = camera.cam_from_world.inverse();
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d ray = camera.unproject(Eigen::Vector2d(x, y));  // z = 1
      const Eigen::Vector3d d = world_from_cam.rotation * ray.normalized(), o = world_from_cam.translation;
      const double b = o.dot(d), c = o.squaredNorm() - 0.25, disc = b * b - c;
      if (disc < 0) continue;
      const double t = -b - std::sqrt(disc);
      frame.depth(y, x) = float(t * ray.normalized().z());
      frame.weight(y, x) = 1.f - 0.3f * float(x) / camera.width;  // weights that differ per pixel
    }
  return frame;
}

TsdfBlocks sphere_blocks(double voxel) {
  const int reach = int(std::ceil(0.62 / voxel));
  return TsdfBlocks::covering(voxel, 4 * voxel, Eigen::Vector3i::Constant(-reach),
                              Eigen::Vector3i::Constant(reach));
}

TEST(TsdfBlocks, CpuReferenceMeasuresTheDistanceToAPlaneAlongTheRay) {
  Camera camera = pinhole(40, 30, Eigen::Vector3d::Zero());
  camera.cam_from_world = Rigid3();
  fusion::DepthFrame frame;
  frame.camera = camera;
  frame.depth = cv::Mat1f(30, 40, 2.f);  // the plane z = 2
  frame.weight = cv::Mat1f(30, 40, 1.f);
  TsdfBlocks blocks = TsdfBlocks::covering(0.05, 0.2, {-8, -8, 32}, {7, 7, 47});
  integrate_blocks_cpu(blocks, frame);
  int checked = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b)
    for (int n = 0; n < kBlockVoxels; ++n) {
      const Eigen::Vector3d p = blocks.position(b, n);
      const double expected = p.norm() * (2 - p.z()) / p.z();
      if (std::abs(expected) > 0.19 || std::abs(p.x() / p.z()) > 0.5 || std::abs(p.y() / p.z()) > 0.35)
        continue;
      ASSERT_GT(blocks.weight[b * kBlockVoxels + n], 0) << p.transpose();
      EXPECT_NEAR(blocks.distance[b * kBlockVoxels + n], expected, 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 1000);
}

TEST(TsdfBlocks, CpuReferenceEqualsTheFusionVolume) {
  const double voxel = 0.04;
  const fusion::DepthFrame frame = sphere_frame(pinhole(80, 60, {0.2, -0.1, -2.0}));
  TsdfBlocks blocks = sphere_blocks(voxel);
  integrate_blocks_cpu(blocks, frame);
  fusion::TsdfVolume volume(fusion::TsdfOptions{voxel, 4 * voxel, 0, false});
  volume.integrate(frame);
  int checked = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b)
    for (int n = 0; n < kBlockVoxels; ++n) {
      const std::size_t i = b * kBlockVoxels + n;
      const auto fused = volume.distance_at(blocks.position(b, n));
      if (blocks.weight[i] == 0 || !fused) continue;
      EXPECT_NEAR(blocks.distance[i], *fused, 1e-6);
      EXPECT_NEAR(blocks.weight[i], volume.weight_at(blocks.position(b, n)), 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 500);
}

TEST(TsdfBlocks, OpenClEqualsCpu) {
  PG_REQUIRE_OPENCL();
  const double voxel = 0.02;
  TsdfBlocks cpu = sphere_blocks(voxel);
  TsdfBlocks gpu = cpu;
  // Two frames: the second averages into the first's values.
  for (const Eigen::Vector3d& centre : {Eigen::Vector3d(0.2, -0.1, -2.0), Eigen::Vector3d(-1.5, 0.3, -1.2)}) {
    fusion::DepthFrame frame = sphere_frame(pinhole(160, 120, centre));
    frame.cos_angle = cv::Mat1f(frame.depth.size(), 0.8f);
    integrate_blocks_cpu(cpu, frame);
    integrate_blocks(gpu, frame, DeviceKind::opencl);
  }
  double largest = 0;
  std::size_t observed = 0;
  for (std::size_t i = 0; i < cpu.distance.size(); ++i) {
    ASSERT_EQ(cpu.weight[i] > 0, gpu.weight[i] > 0) << i;
    if (cpu.weight[i] == 0) continue;
    ++observed;
    largest = std::max({largest, double(std::abs(cpu.distance[i] - gpu.distance[i])),
                        double(std::abs(cpu.weight[i] - gpu.weight[i]))});
  }
  EXPECT_LT(largest, 1e-5);
  EXPECT_GT(observed, 10000u);
}

}  // namespace
}  // namespace pg::gpu
