#pragma once
// Sub-pixel checkerboard corners by fitting a model of the image around each corner: two straight
// edges crossing at the corner, each a smooth step, the model averaged over each pixel's area as a
// sensor (or a box-filtered render) integrates light. The fit is exact for a point-symmetric
// X-junction whatever the edges' angles (perspective), where cv::cornerSubPix's gradient test is
// biased by the pixel grid's phase on sharp edges (~0.05 px RMS on ideal renders).
#include <opencv2/core.hpp>
#include <vector>

#include "pg/calib/board.h"

namespace pg::calib {

// Fit window radius (px) for a view whose smallest square is `smallest_square_px` wide: it must stay
// inside the four squares around a corner.
double corner_fit_radius(double smallest_square_px);

// Refines `corners` (row-major, board.corner_count(), already within about a pixel) in place on `gray`
// (CV_32FC1, any scale). A corner whose fit fails or moves more than a pixel keeps its position.
// Returns the number of corners refined.
int fit_corners(const cv::Mat& gray, const BoardSpec& board, double radius,
                std::vector<cv::Point2f>& corners);

}  // namespace pg::calib
