// Depth accuracy and time on the analytic test scene (exact depth): median and 90th-percentile
// relative error and coverage for each flow preset, epipolar and free.
//   bench_depth [WIDTH]    (default 640; the scene is rendered at WIDTH x 3/4 WIDTH)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "pg/depth/depth_pair.h"
#include "pg/depth/test_scene.h"

int main(int argc, char** argv) {
  const int width = argc > 1 ? std::atoi(argv[1]) : 640;
  const int height = width * 3 / 4;
  const double focal = 0.9375 * width;
  using pg::depth_testing::look_at_camera;
  const pg::Camera left = look_at_camera("left", {-0.15, 0, 0}, {0, 0.1, 4}, width, height, focal);
  const pg::Camera right = look_at_camera("right", {0.15, 0, 0}, {0, 0.1, 4}, width, height, focal);
  const auto left_view = pg::depth_testing::render(left), right_view = pg::depth_testing::render(right);
  std::printf("== Depth on the analytic scene, %dx%d: median / p90 relative error, coverage, time\n", width,
              height);
  for (const char* preset : {"fast", "balanced", "accurate"})
    for (bool epipolar : {true, false}) {
      pg::DepthPairInput input{left_view.image, right_view.image, left, right, {}, {}};
      pg::DepthPairOptions options;
      options.flow = pg::FlowOptions::preset(preset);
      options.epipolar = epipolar;
      const auto start = std::chrono::steady_clock::now();
      const pg::DepthPairResult result = pg::compute_depth_pair(input, options);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::vector<double> errors;
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const float d = result.depth.map.depth.at<float>(y, x), truth = left_view.depth(y, x);
          if (std::isfinite(d)) errors.push_back(std::abs(d - truth) / truth);
        }
      std::sort(errors.begin(), errors.end());
      std::printf("  %-9s %-9s median %.4f%%  p90 %.4f%%  valid %.1f%%  %.2f s (flow %.2f s)\n", preset,
                  epipolar ? "epipolar" : "free", 100 * errors[errors.size() / 2],
                  100 * errors[errors.size() * 9 / 10], 100.0 * errors.size() / (width * height), seconds,
                  result.flow_seconds);
    }
  return 0;
}
