#include "pg/render/texture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {
namespace {

// Half-size level by 2x2 averaging (the last row/column is repeated for odd sizes), which keeps
// constant and (for even sizes) linear textures exact at every level.
cv::Mat half_level(const cv::Mat& src) {
  int w = std::max(1, (src.cols + 1) / 2), h = std::max(1, (src.rows + 1) / 2);
  cv::Mat dst(h, w, CV_32FC3);
  for (int y = 0; y < h; ++y) {
    const cv::Vec3f* r0 = src.ptr<cv::Vec3f>(std::min(2 * y, src.rows - 1));
    const cv::Vec3f* r1 = src.ptr<cv::Vec3f>(std::min(2 * y + 1, src.rows - 1));
    cv::Vec3f* out = dst.ptr<cv::Vec3f>(y);
    for (int x = 0; x < w; ++x) {
      int x0 = std::min(2 * x, src.cols - 1), x1 = std::min(2 * x + 1, src.cols - 1);
      out[x] = (r0[x0] + r0[x1] + r1[x0] + r1[x1]) * 0.25f;
    }
  }
  return dst;
}

int wrap_index(int i, int n, TextureWrap wrap) {
  if (wrap == TextureWrap::clamp) return std::clamp(i, 0, n - 1);
  int r = i % n;
  return r < 0 ? r + n : r;
}

}  // namespace

float srgb_from_linear(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

float linear_from_srgb(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

Texture::Texture(const cv::Mat& image, TextureWrap wrap, bool srgb) : wrap_(wrap) {
  if (image.empty() || image.channels() != 3 || (image.depth() != CV_8U && image.depth() != CV_32F))
    throw UsageError(
        str("texture must be a non-empty CV_8UC3 or CV_32FC3 image (got type ", image.type(), ")"));
  cv::Mat base;
  if (image.depth() == CV_8U) {
    std::array<float, 256> table;
    for (int i = 0; i < 256; ++i) table[i] = srgb ? linear_from_srgb(i / 255.0f) : i / 255.0f;
    base.create(image.size(), CV_32FC3);
    for (int y = 0; y < image.rows; ++y) {
      const cv::Vec3b* in = image.ptr<cv::Vec3b>(y);
      cv::Vec3f* out = base.ptr<cv::Vec3f>(y);
      for (int x = 0; x < image.cols; ++x) out[x] = {table[in[x][0]], table[in[x][1]], table[in[x][2]]};
    }
  } else {
    base = image.clone();
  }
  levels_.push_back(base);
  while (levels_.back().cols > 1 || levels_.back().rows > 1) levels_.push_back(half_level(levels_.back()));
}

Eigen::Vector3f Texture::sample_level(const Eigen::Vector2f& uv, int level) const {
  const cv::Mat& img = levels_[std::clamp(level, 0, level_count() - 1)];
  float fx = uv.x() * img.cols - 0.5f, fy = (1.0f - uv.y()) * img.rows - 0.5f;
  float flx = std::floor(fx), fly = std::floor(fy);
  if (!std::isfinite(flx) || !std::isfinite(fly)) return Eigen::Vector3f::Zero();
  // Keep indices in int range before wrapping (uv far outside [0, 1]).
  flx = std::clamp(flx, -1e6f, 1e6f);
  fly = std::clamp(fly, -1e6f, 1e6f);
  float ax = fx - flx, ay = fy - fly;
  int x0 = wrap_index(int(flx), img.cols, wrap_), x1 = wrap_index(int(flx) + 1, img.cols, wrap_);
  int y0 = wrap_index(int(fly), img.rows, wrap_), y1 = wrap_index(int(fly) + 1, img.rows, wrap_);
  const cv::Vec3f* r0 = img.ptr<cv::Vec3f>(y0);
  const cv::Vec3f* r1 = img.ptr<cv::Vec3f>(y1);
  cv::Vec3f c = (r0[x0] * (1 - ax) + r0[x1] * ax) * (1 - ay) + (r1[x0] * (1 - ax) + r1[x1] * ax) * ay;
  return {c[0], c[1], c[2]};
}

Eigen::Vector3f Texture::sample(const Eigen::Vector2f& uv, float lod) const {
  if (empty()) return Eigen::Vector3f::Zero();
  float l = std::isnan(lod) ? float(level_count() - 1) : std::clamp(lod, 0.0f, float(level_count() - 1));
  int l0 = int(l);
  float a = l - float(l0);
  Eigen::Vector3f c0 = sample_level(uv, l0);
  if (a == 0.0f) return c0;
  return c0 * (1 - a) + sample_level(uv, l0 + 1) * a;
}

float Texture::lod(const Eigen::Vector2f& duv_dx, const Eigen::Vector2f& duv_dy) const {
  const Eigen::Vector2f scale{float(width()), float(height())};
  float fx = duv_dx.cwiseProduct(scale).norm(), fy = duv_dy.cwiseProduct(scale).norm();
  float footprint = std::max(fx, fy);
  if (!(footprint < 1e30f)) return float(level_count() - 1);  // also NaN
  return footprint <= 1.0f ? 0.0f : std::log2(footprint);
}

cv::Mat to_8bit(const cv::Mat& linear, bool srgb) {
  if (linear.depth() != CV_32F) throw UsageError("to_8bit expects a CV_32F image");
  constexpr int kSteps = 1 << 14;  // steps of at most a fifth of an 8-bit level
  std::vector<std::uint8_t> table(kSteps);
  for (int i = 0; i < kSteps; ++i) {
    float c = (i + 0.5f) / float(kSteps);
    table[i] = std::uint8_t(std::lround(255.0f * (srgb ? srgb_from_linear(c) : c)));
  }
  cv::Mat out(linear.size(), CV_MAKETYPE(CV_8U, linear.channels()));
  int n = linear.cols * linear.channels();
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    std::uint8_t* o = out.ptr<std::uint8_t>(y);
    for (int i = 0; i < n; ++i) {
      float c = in[i];
      o[i] = c > 0 ? table[std::min(kSteps - 1, int(c * float(kSteps)))] : 0;  // NaN and negatives -> 0
    }
  }
  return out;
}

}  // namespace pg
