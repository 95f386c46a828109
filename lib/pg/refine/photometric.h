#pragma once
// Photometric agreement between a synthetic view (another photograph projected through the mesh) and
// the real photograph, over the pixels where the synthetic view is valid.
#include <opencv2/core.hpp>

namespace pg {

struct PhotometricError {
  double ncc_error = 0;       // 1 - mean local zero-mean NCC (windows of `window` pixels, textured ones)
  double mean_abs_error = 0;  // mean |synthetic - real|
  std::size_t pixels = 0;     // valid pixels
};

// synthetic, real: CV_32F, same size; valid: CV_8U, nonzero where synthetic holds data. NCC uses the
// windows centred on valid pixels that are at least half valid and have contrast in both images.
PhotometricError photometric_error(const cv::Mat1f& synthetic, const cv::Mat1f& real, const cv::Mat1b& valid,
                                   int window = 7);

// |synthetic - real| per pixel, NaN where not valid.
cv::Mat1f error_image(const cv::Mat1f& synthetic, const cv::Mat1f& real, const cv::Mat1b& valid);

// An 8-bit colour visualisation of an error image: 0 -> dark, `full_scale` and above -> bright
// (inferno colour map); NaN -> black.
cv::Mat error_visualisation(const cv::Mat1f& error, double full_scale = 0.25);

}  // namespace pg
