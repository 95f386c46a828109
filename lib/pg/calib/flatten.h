#pragma once
// Flattening: resampling an image taken through a distorting lens (pinhole with distortion, or fisheye)
// into an undistorted pinhole image of the same size.
#include <opencv2/core.hpp>

#include "pg/camera/camera.h"

namespace pg::calib {

struct FlattenMaps {
  Camera pinhole;              // the flattened camera: same id, size and pose, no distortion, fx = fy
  cv::Mat source_x, source_y;  // CV_32FC1: for each flattened pixel, where to sample the source image
  double valid_fraction = 0;   // flattened pixels that fall inside the source image
};

// alpha = 0: the flattened image holds only valid pixels (zoomed in); alpha = 1: every source pixel is
// kept (black borders); in between, a geometric blend of the two focal lengths. Throws UsageError for
// alpha outside [0, 1] and for equirectangular cameras.
FlattenMaps flatten_maps(const Camera& source, double alpha);

// Resamples (bilinear) keeping the image's depth and channels; pixels from outside the source are 0.
cv::Mat flatten_image(const cv::Mat& image, const FlattenMaps& maps);

}  // namespace pg::calib
