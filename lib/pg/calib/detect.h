#pragma once
// Checkerboard corner detection with sub-pixel accuracy and rejection of views a calibration cannot
// use (board not found, too small, seen edge-on, folded grid).
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pg/calib/board.h"

namespace pg::calib {

enum class Detector {
  automatic,     // sector-based first, the classic detector when it finds nothing
  sector_based,  // cv::findChessboardCornersSB
  classic,       // cv::findChessboardCorners
  // Either way the corners are then refined with cv::cornerSubPix in a window fitted to the view and
  // by fitting an X-junction model to the full-depth image (corner_fit.h).
};
Detector detector_from_string(const std::string& name);  // "auto", "sb", "classic"; UsageError otherwise
std::string to_string(Detector detector);

struct Detection {
  bool found = false;
  std::string problem;               // why the view is not usable, when !found
  std::vector<cv::Point2f> corners;  // row-major, board.corner_count() of them
  std::string method;                // "sector-based" or "classic"
  double smallest_square_px = 0;     // shortest distance between neighbouring corners
  int subpix_half_window = 0;        // the cornerSubPix half-window used
};

// `image` may be grey or colour, 8-bit, 16-bit or float; it is converted to 8-bit grey for the
// detectors.
Detection detect_board(const cv::Mat& image, const BoardSpec& board, Detector detector = Detector::automatic);

// The cornerSubPix half-window for a view whose smallest square is `smallest_square_px` wide: the
// window must stay inside the four squares around a corner, or the neighbouring corners' edges pull
// the estimate (OpenCV's 23x23 default-sample window biases views with small squares).
int subpix_half_window(double smallest_square_px);

// Shortest distance between horizontally or vertically neighbouring corners.
double smallest_square(const std::vector<cv::Point2f>& corners, const BoardSpec& board);

// Why these corners make a degenerate view (empty when they are fine): a board that covers almost
// nothing, squares too small to locate, a board seen edge-on, or a folded grid.
std::string degeneracy(const std::vector<cv::Point2f>& corners, const BoardSpec& board, cv::Size image_size);

// 8-bit single-channel copy of any image read_image returns (float data is taken as [0, 1]).
cv::Mat to_gray8(const cv::Mat& image);

}  // namespace pg::calib
