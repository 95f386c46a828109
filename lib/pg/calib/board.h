#pragma once
// The calibration target: a checkerboard described by its inner corners and square size.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace pg::calib {

struct BoardSpec {
  int cols = 9;                // inner corners across (OpenCV's patternSize.width)
  int rows = 6;                // inner corners down
  double square_size = 0.025;  // metres

  int corner_count() const { return cols * rows; }
  cv::Size pattern_size() const { return {cols, rows}; }
  // Throws UsageError when the board cannot be detected unambiguously (fewer than 3x3 corners,
  // a non-positive square size).
  void check() const;
};

// "COLSxROWS" inner corners (e.g. "9x6") and the square size in metres; UsageError when malformed.
BoardSpec parse_board(const std::string& text, double square);

// Corner positions on the board plane (z = 0), row-major as OpenCV orders detections, in metres.
std::vector<cv::Point3f> board_points(const BoardSpec& board);

}  // namespace pg::calib
