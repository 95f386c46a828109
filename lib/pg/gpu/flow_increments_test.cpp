#include "pg/gpu/flow_increments.h"

#include <gtest/gtest.h>

#include <cmath>

#include "pg/gpu/test_support.h"

namespace pg::gpu {
namespace {

// A textured image moved by a constant (du, dv): linearised brightness constancy
// ix du + iy dv + it = 0 with it = -(ix du + iy dv) has that motion as its exact solution, and a
// constant flow costs no smoothness, so the increments converge to it.
FlowIncrementInput translation_problem(int cols, int rows, float du, float dv) {
  FlowIncrementInput in;
  for (auto* set : {&in.brightness, &in.gradient})
    for (cv::Mat1f& m : *set) m = cv::Mat1f::zeros(rows, cols);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      const float ix = std::cos(0.21f * x + 0.05f * y) + 0.4f * std::sin(0.13f * y);
      const float iy = std::sin(0.17f * y - 0.07f * x) + 0.3f * std::cos(0.11f * x);
      const float it = -(ix * du + iy * dv);
      const float j[6] = {ix * ix, ix * iy, iy * iy, ix * it, iy * it, it * it};
      for (int k = 0; k < 6; ++k) in.brightness[k](y, x) = j[k];
      // A gradient-constancy tensor with the same solution, from a second texture.
      const float gx = std::sin(0.3f * x) * std::cos(0.2f * y), gy = std::cos(0.25f * y + 0.1f * x);
      const float gt = -(gx * du + gy * dv);
      const float g[6] = {gx * gx, gx * gy, gy * gy, gx * gt, gy * gt, gt * gt};
      for (int k = 0; k < 6; ++k) in.gradient[k](y, x) = 0.1f * g[k];
    }
  in.smoothness = cv::Mat1f(rows, cols, 0.02f);
  in.u = cv::Mat1f::zeros(rows, cols);
  in.v = cv::Mat1f::zeros(rows, cols);
  return in;
}

double largest_difference(const cv::Mat1f& a, const cv::Mat1f& b) {
  return cv::norm(a, b, cv::NORM_INF);
}

TEST(FlowIncrements, CpuReferenceConvergesToTheTranslation) {
  FlowIncrementInput in = translation_problem(64, 48, 0.3f, -0.2f);
  in.options.fixed_point_iterations = 10;
  in.options.sor_iterations = 30;
  cv::Mat1f du, dv;
  flow_increments_cpu(in, du, dv);
  const cv::Rect inner(4, 4, 56, 40);
  EXPECT_LT(cv::norm(du(inner) - 0.3f, cv::NORM_INF), 0.01);
  EXPECT_LT(cv::norm(dv(inner) + 0.2f, cv::NORM_INF), 0.01);
}

TEST(FlowIncrements, OpenClEqualsCpu) {
  PG_REQUIRE_OPENCL();
  // Odd sizes exercise the borders and the red-black split of an odd row length.
  for (const cv::Size size : {cv::Size(67, 45), cv::Size(128, 96)}) {
    FlowIncrementInput in = translation_problem(size.width, size.height, 0.7f, 0.4f);
    // A non-zero starting flow with structure, so the smoothness weights vary.
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        in.u(y, x) = 0.3f * std::sin(0.1f * x) + (x > size.width / 2 ? 0.5f : 0.f);
        in.v(y, x) = 0.2f * std::cos(0.15f * y);
      }
    cv::Mat1f du_cpu, dv_cpu, du_cl, dv_cl;
    flow_increments_cpu(in, du_cpu, dv_cpu);
    flow_increments(in, du_cl, dv_cl, DeviceKind::opencl);
    EXPECT_LT(largest_difference(du_cpu, du_cl), 1e-4) << size;
    EXPECT_LT(largest_difference(dv_cpu, dv_cl), 1e-4) << size;
    EXPECT_GT(cv::norm(du_cpu, cv::NORM_INF), 0.1);  // the comparison is not between zeros
  }
}

TEST(FlowIncrements, CudaEqualsCpu) {
  const std::string reason = cuda_unavailable_reason();
  if (!reason.empty()) GTEST_SKIP() << "no CUDA device (" << reason << ")";
  FlowIncrementInput in = translation_problem(67, 45, 0.7f, 0.4f);
  cv::Mat1f du_cpu, dv_cpu, du_cuda, dv_cuda;
  flow_increments_cpu(in, du_cpu, dv_cpu);
  flow_increments(in, du_cuda, dv_cuda, DeviceKind::cuda);
  EXPECT_LT(largest_difference(du_cpu, du_cuda), 1e-4);
  EXPECT_LT(largest_difference(dv_cpu, dv_cuda), 1e-4);
}

TEST(FlowIncrements, CpuDeviceRunsTheReference) {
  const FlowIncrementInput in = translation_problem(20, 10, 0.1f, 0.1f);
  cv::Mat1f du_a, dv_a, du_b, dv_b;
  flow_increments_cpu(in, du_a, dv_a);
  flow_increments(in, du_b, dv_b, DeviceKind::cpu);
  EXPECT_EQ(largest_difference(du_a, du_b), 0);
  EXPECT_EQ(largest_difference(dv_a, dv_b), 0);
}

// The epipolar mode on a horizontal line field: a pixel-wise constant disparity t along d = (-1, 0)
// solves the brightness tensor built for the 2-D motion (-t, 0), so ds converges to t.
LineIncrementInput line_problem(int cols, int rows, float t) {
  const FlowIncrementInput flow = translation_problem(cols, rows, -t, 0.f);
  LineIncrementInput in;
  in.brightness = flow.brightness, in.gradient = flow.gradient, in.smoothness = flow.smoothness;
  in.s = cv::Mat1f::zeros(rows, cols);
  in.direction = cv::Mat2f(rows, cols, cv::Vec2f(-1, 0));
  return in;
}

TEST(LineIncrements, CpuReferenceConvergesToTheDisparity) {
  LineIncrementInput in = line_problem(64, 48, 0.6f);
  in.options.fixed_point_iterations = 10;
  in.options.sor_iterations = 30;
  cv::Mat1f ds;
  line_increments_cpu(in, ds);
  EXPECT_LT(cv::norm(ds(cv::Rect(4, 4, 56, 40)) - 0.6f, cv::NORM_INF), 0.01);
}

// Curved lines, a discontinuous start and one pixel without a line: `device` against the CPU.
void expect_line_increments_equal_cpu(DeviceKind device) {
  for (const cv::Size size : {cv::Size(67, 45), cv::Size(128, 96)}) {
    LineIncrementInput in = line_problem(size.width, size.height, 0.8f);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        in.s(y, x) = 0.3f * std::sin(0.1f * x) + (x > size.width / 2 ? 0.5f : 0.f);
        in.direction(y, x) = cv::Vec2f(-std::cos(0.01f * y), std::sin(0.01f * y));
      }
    in.direction(3, 5) = cv::Vec2f(std::nanf(""), std::nanf(""));  // a pixel without a line
    cv::Mat1f ds_cpu, ds_device;
    line_increments_cpu(in, ds_cpu);
    line_increments(in, ds_device, device);
    EXPECT_LT(largest_difference(ds_cpu, ds_device), 1e-4) << size;
    EXPECT_GT(cv::norm(ds_cpu, cv::NORM_INF), 0.1);
    EXPECT_TRUE(std::isfinite(ds_device(3, 5)));
  }
}

TEST(LineIncrements, OpenClEqualsCpu) {
  PG_REQUIRE_OPENCL();
  expect_line_increments_equal_cpu(DeviceKind::opencl);
}

TEST(LineIncrements, CudaEqualsCpu) {
  const std::string reason = cuda_unavailable_reason();
  if (!reason.empty()) GTEST_SKIP() << "no CUDA device (" << reason << ")";
  expect_line_increments_equal_cpu(DeviceKind::cuda);
}

// A level with structure in every row (a flow step, row-varying smoothness) and options whose reach
// (2 * (2 * 3 + 3) = 18 rows) is smaller than the image, so that bands of 20 rows have real halos.
FlowIncrementInput banding_problem() {
  FlowIncrementInput in = translation_problem(67, 130, 0.7f, -0.4f);
  for (int y = 0; y < in.u.rows; ++y)
    for (int x = 0; x < in.u.cols; ++x) {
      in.u(y, x) = 0.3f * std::sin(0.1f * x) + (y > 70 ? 0.5f : 0.f);
      in.smoothness(y, x) = 0.02f * (1.5f + std::sin(0.2f * y));
    }
  in.options.fixed_point_iterations = 2;
  in.options.sor_iterations = 3;
  return in;
}

TEST(FlowIncrements, BandsWithHalosGiveTheWholeLevelsResult) {
  const FlowIncrementInput in = banding_problem();
  ASSERT_EQ(increments_reach(in.options), 18);
  cv::Mat1f du, dv, du_banded, dv_banded;
  flow_increments_cpu(in, du, dv);
  // On the CPU the bands reproduce the whole level bit for bit: no row's result reaches further.
  flow_increments_banded(in, du_banded, dv_banded, DeviceKind::cpu, 20);
  EXPECT_EQ(largest_difference(du, du_banded), 0);
  EXPECT_EQ(largest_difference(dv, dv_banded), 0);
  EXPECT_GT(cv::norm(du, cv::NORM_INF), 0.1);
  if (!opencl_unavailable_reason().empty()) GTEST_SKIP() << "no OpenCL device for the device bands";
  flow_increments_banded(in, du_banded, dv_banded, DeviceKind::opencl, 20);
  EXPECT_LT(largest_difference(du, du_banded), 1e-4);
  EXPECT_LT(largest_difference(dv, dv_banded), 1e-4);
}

TEST(LineIncrements, BandsWithHalosGiveTheWholeLevelsResult) {
  const FlowIncrementInput flow = banding_problem();
  LineIncrementInput in;
  in.brightness = flow.brightness, in.gradient = flow.gradient, in.smoothness = flow.smoothness;
  in.options = flow.options;
  in.s = flow.u.clone();
  in.direction = cv::Mat2f(flow.u.size());
  for (int y = 0; y < in.s.rows; ++y)
    for (int x = 0; x < in.s.cols; ++x)
      in.direction(y, x) = cv::Vec2f(-std::cos(0.01f * y), std::sin(0.01f * y));
  cv::Mat1f ds, ds_banded;
  line_increments_cpu(in, ds);
  line_increments_banded(in, ds_banded, DeviceKind::cpu, 20);
  EXPECT_EQ(largest_difference(ds, ds_banded), 0);
  EXPECT_GT(cv::norm(ds, cv::NORM_INF), 0.1);
  if (!opencl_unavailable_reason().empty()) GTEST_SKIP() << "no OpenCL device for the device bands";
  line_increments_banded(in, ds_banded, DeviceKind::opencl, 20);
  EXPECT_LT(largest_difference(ds, ds_banded), 1e-4);
}

TEST(DeviceFootprint, BandRowsLeaveRoomForTwoHalos) {
  const cv::Size size(1000, 500);
  const FlowIncrementOptions defaults;  // reach 115 rows, halos of 116 (even)
  DeviceInfo device;
  device.kind = DeviceKind::opencl;
  device.global_memory = increments_footprint(size, IncrementMode::free).total;
  device.max_allocation = device.global_memory;
  EXPECT_EQ(increments_band_rows(size, IncrementMode::free, defaults, device), 500);  // one piece
  device.global_memory = increments_footprint({1000, 301}, IncrementMode::free).total;
  EXPECT_EQ(increments_band_rows(size, IncrementMode::free, defaults, device), 301 - 2 * 116 - 1);
  device.global_memory = increments_footprint({1000, 233}, IncrementMode::free).total;
  EXPECT_EQ(increments_band_rows(size, IncrementMode::free, defaults, device), 0);        // halos only
  EXPECT_EQ(increments_band_rows(size, IncrementMode::free, defaults, DeviceInfo{}), 0);  // the CPU
}

TEST(DeviceFootprint, CountsEveryPlaneAndComparesWithTheDeviceLimits) {
  const cv::Size size(1000, 500);
  const std::uint64_t plane = 1000 * 500 * 4;
  const DeviceFootprint free = increments_footprint(size, IncrementMode::free);
  EXPECT_EQ(free.total, 25 * plane);
  EXPECT_EQ(free.largest_buffer, 6 * plane);
  EXPECT_EQ(increments_footprint(size, IncrementMode::line).total, 22 * plane);
  DeviceInfo device;
  device.kind = DeviceKind::opencl;
  device.global_memory = 25 * plane, device.max_allocation = 6 * plane;
  EXPECT_TRUE(fits_on(free, device));
  device.max_allocation = 6 * plane - 1;  // one tensor buffer too large
  EXPECT_FALSE(fits_on(free, device));
  device.max_allocation = 6 * plane, device.global_memory = 25 * plane - 1;
  EXPECT_FALSE(fits_on(free, device));
  EXPECT_FALSE(fits_on(free, DeviceInfo{}));  // the CPU has no device memory to fit
}

}  // namespace
}  // namespace pg::gpu
