#pragma once
// Textures with a mip pyramid and trilinear sampling, and conversions of linear colour images.
// UV convention (as OBJ and PLY): u to the right, v up; (0, 0) is the bottom-left corner of the image,
// so texel (x, y) has its centre at u = (x + 0.5) / width, v = 1 - (y + 0.5) / height.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

namespace pg {

enum class TextureWrap { clamp, repeat };

class Texture {
 public:
  Texture() = default;
  // image: CV_8UC3 (sRGB-encoded, decoded to linear when `srgb` is true) or CV_32FC3 (linear).
  // Channel order is kept as given (BGR for images read by OpenCV).
  explicit Texture(const cv::Mat& image, TextureWrap wrap = TextureWrap::clamp, bool srgb = true);

  bool empty() const { return levels_.empty(); }
  int width() const { return empty() ? 0 : levels_[0].cols; }
  int height() const { return empty() ? 0 : levels_[0].rows; }
  int level_count() const { return int(levels_.size()); }
  // Mip level i (CV_32FC3): level 0 is the image, each next level halves the size by 2x2 averaging.
  const cv::Mat& level(int i) const { return levels_[i]; }

  // Bilinear sample of one level.
  Eigen::Vector3f sample_level(const Eigen::Vector2f& uv, int level) const;
  // Trilinear sample; lod = log2 of the pixel footprint in level-0 texels (clamped to the pyramid).
  Eigen::Vector3f sample(const Eigen::Vector2f& uv, float lod) const;
  // The level of detail for a pixel whose uv changes by duv_dx, duv_dy to its neighbours.
  float lod(const Eigen::Vector2f& duv_dx, const Eigen::Vector2f& duv_dy) const;

 private:
  std::vector<cv::Mat> levels_;
  TextureWrap wrap_ = TextureWrap::clamp;
};

// sRGB transfer functions on one linear / encoded value in [0, 1].
float srgb_from_linear(float linear);
float linear_from_srgb(float encoded);

// Linear CV_32FC3 (or C1) -> CV_8UC3 (or C1): sRGB-encoded when `srgb`, else scaled linearly;
// values are clamped to [0, 1] and NaN becomes 0.
cv::Mat to_8bit(const cv::Mat& linear, bool srgb = true);

}  // namespace pg
