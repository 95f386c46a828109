#pragma once
// The relative pose of two calibrated cameras that photographed the same board positions.
#include <vector>

#include "pg/calib/calibrate.h"

namespace pg::calib {

struct StereoResult {
  Rigid3 second_from_first;  // maps points in the first camera's frame into the second's
  double baseline = 0;       // distance between the centres, in the board's units (metres)
  double rms = 0;            // px per corner, both cameras, intrinsics held
  int pairs = 0;
  // Pairs whose second view listed the corners from the other end of the board (a point-symmetric
  // board, or a detector that started from the other corner) and were put in the first's order.
  int reversed_orders = 0;
};

// first[i] and second[i] must show the same board position, their corners listed from either end:
// a second view whose order disagrees with the relative pose most pairs give is reversed. Intrinsics are held
// (cv::stereoCalibrate or cv::fisheye::stereoCalibrate with CALIB_FIX_INTRINSIC). Throws FailedError for
// fewer than 3 pairs, or cameras of different models.
StereoResult stereo_calibrate(const std::vector<ViewInput>& first, const std::vector<ViewInput>& second,
                              const BoardSpec& board, const Camera& first_camera,
                              const Camera& second_camera);

}  // namespace pg::calib
