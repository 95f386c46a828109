#include "pg/flow/flow_color.h"

#include <array>
#include <cmath>
#include <numbers>
#include <vector>

namespace pg {
namespace {

// The 55 colours of the Middlebury wheel: red-yellow 15, yellow-green 6, green-cyan 4, cyan-blue 11,
// blue-magenta 13, magenta-red 6 (RGB).
std::vector<std::array<float, 3>> colour_wheel() {
  std::vector<std::array<float, 3>> wheel;
  const auto ramp = [&](int n, auto colour) {
    for (int i = 0; i < n; ++i)
      wheel.push_back(colour(255.f * static_cast<float>(i) / static_cast<float>(n)));
  };
  ramp(15, [](float t) { return std::array<float, 3>{255, t, 0}; });
  ramp(6, [](float t) { return std::array<float, 3>{255 - t, 255, 0}; });
  ramp(4, [](float t) { return std::array<float, 3>{0, 255, t}; });
  ramp(11, [](float t) { return std::array<float, 3>{0, 255 - t, 255}; });
  ramp(13, [](float t) { return std::array<float, 3>{t, 0, 255}; });
  ramp(6, [](float t) { return std::array<float, 3>{255, 0, 255 - t}; });
  return wheel;
}

}  // namespace

cv::Mat3b flow_to_color(const cv::Mat2f& flow, double max_magnitude) {
  if (max_magnitude <= 0) {
    max_magnitude = 0;
    for (const cv::Vec2f& f : flow)
      if (std::isfinite(f[0]) && std::isfinite(f[1]))
        max_magnitude = std::max(max_magnitude, std::hypot(f[0], f[1]) * 1.0);
    if (max_magnitude == 0) max_magnitude = 1;
  }
  static const std::vector<std::array<float, 3>> wheel = colour_wheel();
  const int n = static_cast<int>(wheel.size());
  cv::Mat3b out(flow.size(), cv::Vec3b(0, 0, 0));
  for (int y = 0; y < flow.rows; ++y)
    for (int x = 0; x < flow.cols; ++x) {
      const float u = flow(y, x)[0] / static_cast<float>(max_magnitude);
      const float v = flow(y, x)[1] / static_cast<float>(max_magnitude);
      if (!std::isfinite(u) || !std::isfinite(v)) continue;
      const float radius = std::min(1.f, std::hypot(u, v));
      const float angle = std::atan2(-v, -u) / std::numbers::pi_v<float>;  // in [-1, 1]
      const float position = (angle + 1) / 2 * static_cast<float>(n - 1);
      const int k0 = static_cast<int>(position), k1 = (k0 + 1) % n;
      const float t = position - static_cast<float>(k0);
      cv::Vec3b& pixel = out(y, x);
      for (int c = 0; c < 3; ++c) {
        const float colour = ((1 - t) * wheel[k0][c] + t * wheel[k1][c]) / 255.f;
        const float value = 1 - radius * (1 - colour);                          // white at zero motion
        pixel[2 - c] = static_cast<unsigned char>(std::lround(255.f * value));  // RGB -> BGR
      }
    }
  return out;
}

}  // namespace pg
