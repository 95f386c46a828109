// The whole flow solver with its inner iterations on the OpenCL device (PoCL here) against the CPU
// reference, in both modes, on a synthetic pair with a known smooth flow and on real photographs
// (MPI-Sintel, Middlebury; on CUDA too where a CUDA device is usable). Skips without OpenCL.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "pg/flow/flow.h"
#include "pg/flow/level_solver.h"
#include "pg/gpu/device.h"
#include "pg/gpu/flow_increments.h"
#include "pg/gpu/flow_level.h"
#include "pg/gpu/test_support.h"
#include "pg/image/image_io.h"
#include "pg/testing/testing.h"

namespace {

constexpr double pi = 3.14159265358979323846;

// A smooth random colour texture (blurred noise), 8-bit.
cv::Mat3b texture(cv::Size size, int seed) {
  cv::Mat3f noise(size);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 1);
  cv::GaussianBlur(noise, noise, {0, 0}, 2.0);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  cv::Mat3b out;
  noise.convertTo(out, CV_8U);
  return out;
}

// A pair whose exact flow is known: `to` samples `from` at p - m(p) for a smooth motion m given on
// `to`'s pixels, so the flow of `from`'s pixel x is m(p) at the p with p = x + m(p) (fixed point).
struct SyntheticPair {
  cv::Mat3b from, to;
  cv::Mat2f truth;
};

template <class Motion>
SyntheticPair warped_pair(cv::Size size, const Motion& motion) {
  SyntheticPair pair;
  pair.from = texture(size, 7);
  cv::Mat1f map_x(size), map_y(size);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const cv::Vec2f m = motion(float(x), float(y));
      map_x(y, x) = float(x) - m[0], map_y(y, x) = float(y) - m[1];
    }
  cv::remap(pair.from, pair.to, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  pair.truth.create(size);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      cv::Vec2f m = motion(float(x), float(y));
      for (int i = 0; i < 20; ++i) m = motion(float(x) + m[0], float(y) + m[1]);
      pair.truth(y, x) = m;
    }
  return pair;
}

// Mean end-point error between two flows away from the border (where the pair has no content).
double mean_epe(const cv::Mat2f& a, const cv::Mat2f& b, int margin = 16) {
  double sum = 0;
  int n = 0;
  for (int y = margin; y < a.rows - margin; ++y)
    for (int x = margin; x < a.cols - margin; ++x, ++n) sum += cv::norm(a(y, x) - b(y, x));
  return sum / n;
}

// Runs `solve` with the device set to `kind`, restoring the automatic choice after.
template <class Solve>
auto on_device(pg::gpu::DeviceKind kind, const Solve& solve) {
  pg::gpu::set_requested_device(kind);
  auto result = solve();
  pg::gpu::set_requested_device(pg::gpu::DeviceKind::automatic);
  return result;
}

// The measured errors, in the test's XML output (--gtest_output=xml).
void record(double cpu_error, double opencl_error, double difference) {
  ::testing::Test::RecordProperty("cpu_epe", std::to_string(cpu_error));
  ::testing::Test::RecordProperty("opencl_epe", std::to_string(opencl_error));
  ::testing::Test::RecordProperty("cpu_opencl_epe", std::to_string(difference));
}

TEST(FlowDevice, FreeFlowOnOpenClMatchesTheCpuWithinAHundredthOfAPixel) {
  PG_REQUIRE_OPENCL();
  const SyntheticPair pair = warped_pair({256, 192}, [](float x, float y) {
    return cv::Vec2f(1.5f + 1.2f * float(std::sin(2 * pi * x / 256)),
                     -0.8f + 0.9f * float(std::cos(2 * pi * y / 192)));
  });
  const auto solve = [&] { return pg::compute_flow(pair.from, pair.to); };
  const cv::Mat2f cpu = on_device(pg::gpu::DeviceKind::cpu, solve);
  const cv::Mat2f opencl = on_device(pg::gpu::DeviceKind::opencl, solve);
  const double cpu_error = mean_epe(cpu, pair.truth), opencl_error = mean_epe(opencl, pair.truth);
  record(cpu_error, opencl_error, mean_epe(cpu, opencl));
  EXPECT_LT(cpu_error, 0.1);
  EXPECT_LT(opencl_error, 0.1);
  EXPECT_LT(std::abs(cpu_error - opencl_error), 0.01);
  EXPECT_LT(mean_epe(cpu, opencl), 0.01);  // the flows themselves agree, not only their accuracy
}

TEST(FlowDevice, EpipolarFlowOnOpenClMatchesTheCpuWithinAHundredthOfAPixel) {
  PG_REQUIRE_OPENCL();
  // A rectified pair: disparity to the left, varying smoothly over the image.
  const auto disparity = [](float x, float y) {
    return 3.f + 1.5f * float(std::sin(2 * pi * x / 256) * std::cos(2 * pi * y / 192));
  };
  const SyntheticPair pair =
      warped_pair({256, 192}, [&](float x, float y) { return cv::Vec2f(-disparity(x, y), 0.f); });
  const pg::EpipolarField field{cv::Mat2f(pair.from.size(), cv::Vec2f(0, 0)),
                                cv::Mat2f(pair.from.size(), cv::Vec2f(-1, 0))};
  const auto solve = [&] { return pg::compute_epipolar_flow(pair.from, pair.to, field).flow; };
  const cv::Mat2f cpu = on_device(pg::gpu::DeviceKind::cpu, solve);
  const cv::Mat2f opencl = on_device(pg::gpu::DeviceKind::opencl, solve);
  const double cpu_error = mean_epe(cpu, pair.truth), opencl_error = mean_epe(opencl, pair.truth);
  record(cpu_error, opencl_error, mean_epe(cpu, opencl));
  EXPECT_LT(cpu_error, 0.1);
  EXPECT_LT(opencl_error, 0.1);
  EXPECT_LT(std::abs(cpu_error - opencl_error), 0.01);
  EXPECT_LT(mean_epe(cpu, opencl), 0.01);
}

TEST(FlowDevice, LevelsTooLargeForTheDeviceAreSolvedInBandsWithTheSameResult) {
  PG_REQUIRE_OPENCL();
  const SyntheticPair pair = warped_pair({256, 192}, [](float x, float y) {
    return cv::Vec2f(1.5f + 1.2f * float(std::sin(2 * pi * x / 256)),
                     -0.8f + 0.9f * float(std::cos(2 * pi * y / 192)));
  });
  pg::FlowOptions options;
  options.fixed_point_iterations = 2;  // a reach of 2 * (2 * 5 + 3) = 26 rows, so bands fit below 192
  options.sor_iterations = 5;
  const auto solve = [&] { return pg::compute_flow(pair.from, pair.to, options); };
  const cv::Mat2f cpu = on_device(pg::gpu::DeviceKind::cpu, solve);
  // Room for 120 rows of the finest level (25 planes of 256 floats each): it runs in bands of 120 -
  // 2 * 26 = 68 rows, the coarser levels in one piece.
  pg::gpu::limit_flow_device_memory(25ull * 256 * 4 * 120);
  ASSERT_EQ(pg::gpu::increments_band_rows({256, 192}, pg::gpu::IncrementMode::free,
                                          {.fixed_point_iterations = 2, .sor_iterations = 5},
                                          pg::gpu::flow_device_info(pg::gpu::DeviceKind::opencl)),
            68);
  const cv::Mat2f banded = on_device(pg::gpu::DeviceKind::opencl, solve);
  pg::gpu::limit_flow_device_memory(0);
  const double cpu_error = mean_epe(cpu, pair.truth), banded_error = mean_epe(banded, pair.truth);
  record(cpu_error, banded_error, mean_epe(cpu, banded));
  EXPECT_LT(cpu_error, 0.1);
  EXPECT_LT(std::abs(cpu_error - banded_error), 0.01);
  EXPECT_LT(mean_epe(cpu, banded), 0.01);
}

// The accelerated backends a real-data comparison runs on: OpenCL, and CUDA where usable.
std::vector<pg::gpu::DeviceKind> accelerated_kinds() {
  std::vector<pg::gpu::DeviceKind> kinds{pg::gpu::DeviceKind::opencl};
  if (pg::gpu::cuda_unavailable_reason().empty()) kinds.push_back(pg::gpu::DeviceKind::cuda);
  return kinds;
}

// A level's warp on the device: the derivatives, the bilinear warp and the twelve tensor planes equal
// the CPU solver's to rounding, for a colour pair and a flow that leaves the image near its borders.
TEST(FlowDevice, WarpTensorsOnTheDeviceEqualTheCpu) {
  PG_REQUIRE_OPENCL();
  const cv::Size size(203, 157);
  std::vector<cv::Mat1f> from, to;
  for (const auto& [image, channels] :
       {std::pair{texture(size, 3), &from}, std::pair{texture(size, 4), &to}}) {
    std::vector<cv::Mat> planes;
    cv::split(image, planes);
    for (const cv::Mat& p : planes) {
      cv::Mat1f channel;
      p.convertTo(channel, CV_32F, 1.0 / 255);
      channels->push_back(channel);
    }
  }
  cv::Mat1f u(size), v(size);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      u(y, x) = 6.f * float(std::sin(0.05 * x + 0.02 * y)) + 0.37f;
      v(y, x) = -5.f * float(std::cos(0.03 * y - 0.04 * x)) - 0.21f;
    }
  for (const double zeta : {0.0004, 0.0}) {
    pg::FlowOptions options;
    options.zeta = zeta;
    pg::flow_detail::PlanePool pool(size);
    const pg::flow_detail::LevelImages level = pg::flow_detail::prepare_level(from, to, options, pool);
    pg::flow_detail::LevelSolver solver(size, options);
    const std::array<cv::Mat1f, 12> cpu = solver.tensors(level, u, v);
    for (const pg::gpu::DeviceKind kind : accelerated_kinds()) {
      pg::gpu::FlowLevel device(kind, from, to, level.smoothness, float(zeta * zeta));
      const std::array<cv::Mat1f, 12> on_device = device.tensors(u, v);
      for (int k = 0; k < 12; ++k) {
        const double scale = std::max(1.0, cv::norm(cpu[k], cv::NORM_INF));
        EXPECT_LE(cv::norm(cpu[k], on_device[k], cv::NORM_INF), 1e-5 * scale)
            << pg::gpu::to_string(kind) << " zeta " << zeta << " plane " << k;
      }
    }
  }
}

// Real photographs, where nothing is smooth or synthetic: MPI-Sintel's alley (1024x436, free flow)
// and Middlebury's Venus (434x383, epipolar): the device's flow within a hundredth of a pixel of the
// CPU's, on average over every pixel.
TEST(FlowDevice, SintelAlleyOnTheDeviceMatchesTheCpu) {
  PG_REQUIRE_OPENCL();
  PG_REQUIRE_REAL_DATA(dir, "flow/sintel/clean/alley_1");
  const cv::Mat a = pg::read_image(dir / "frame_0002.png"), b = pg::read_image(dir / "frame_0003.png");
  const auto solve = [&] { return pg::compute_flow(a, b, pg::FlowOptions::preset("fast")); };
  const cv::Mat2f cpu = on_device(pg::gpu::DeviceKind::cpu, solve);
  for (const pg::gpu::DeviceKind kind : accelerated_kinds()) {
    const double difference = mean_epe(cpu, on_device(kind, solve), 0);
    ::testing::Test::RecordProperty("cpu_" + pg::gpu::to_string(kind) + "_epe", std::to_string(difference));
    EXPECT_LT(difference, 0.01) << pg::gpu::to_string(kind);
  }
}

TEST(FlowDevice, MiddleburyVenusEpipolarOnTheDeviceMatchesTheCpu) {
  PG_REQUIRE_OPENCL();
  PG_REQUIRE_REAL_DATA(dir, "stereo/middlebury/venus");
  const cv::Mat a = pg::read_image(dir / "im2.png"), b = pg::read_image(dir / "im6.png");
  const pg::EpipolarField field{cv::Mat2f(a.size(), cv::Vec2f(0, 0)), cv::Mat2f(a.size(), cv::Vec2f(-1, 0))};
  const auto solve = [&] {
    return pg::compute_epipolar_flow(a, b, field, pg::FlowOptions::preset("fast")).flow;
  };
  const cv::Mat2f cpu = on_device(pg::gpu::DeviceKind::cpu, solve);
  for (const pg::gpu::DeviceKind kind : accelerated_kinds()) {
    const double difference = mean_epe(cpu, on_device(kind, solve), 0);
    ::testing::Test::RecordProperty("cpu_" + pg::gpu::to_string(kind) + "_epe", std::to_string(difference));
    EXPECT_LT(difference, 0.01) << pg::gpu::to_string(kind);
  }
}

}  // namespace
