#include "pg/calib/detect.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "pg/calib/corner_fit.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/image_io.h"

namespace pg::calib {

Detector detector_from_string(const std::string& name) {
  if (name == "auto") return Detector::automatic;
  if (name == "sb") return Detector::sector_based;
  if (name == "classic") return Detector::classic;
  throw UsageError("unknown detector \"" + name + "\" (expected auto, sb or classic)");
}

std::string to_string(Detector detector) {
  switch (detector) {
    case Detector::automatic:
      return "auto";
    case Detector::sector_based:
      return "sb";
    case Detector::classic:
      return "classic";
  }
  return "auto";
}

cv::Mat to_gray8(const cv::Mat& image) {
  cv::Mat gray;
  if (image.channels() == 1)
    gray = image;
  else if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  if (gray.depth() == CV_8U) return gray;
  cv::Mat out;
  if (gray.depth() == CV_16U)
    gray.convertTo(out, CV_8U, 1.0 / 257.0);
  else
    gray.convertTo(out, CV_8U, 255.0);  // float in [0, 1]; saturating
  return out;
}

double smallest_square(const std::vector<cv::Point2f>& corners, const BoardSpec& board) {
  double smallest = std::numeric_limits<double>::infinity();
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c < board.cols; ++c) {
      const cv::Point2f p = corners[r * board.cols + c];
      if (c + 1 < board.cols)
        smallest = std::min(smallest, double(cv::norm(corners[r * board.cols + c + 1] - p)));
      if (r + 1 < board.rows)
        smallest = std::min(smallest, double(cv::norm(corners[(r + 1) * board.cols + c] - p)));
    }
  return smallest;
}

int subpix_half_window(double smallest_square_px) {
  // Measured on OpenCV's sample boards: RMS falls as the window grows up to about 0.35 x the smallest
  // square and jumps past 0.4 (the window then reaches the neighbouring corners' edges under
  // perspective); 0.3 keeps a margin.
  return std::clamp(int(0.3 * smallest_square_px), 2, 12);
}

std::string degeneracy(const std::vector<cv::Point2f>& corners, const BoardSpec& board, cv::Size image_size) {
  const double square = smallest_square(corners, board);
  if (square < 5) return str("squares too small to locate (", square, " px)");
  std::vector<cv::Point2f> hull;
  cv::convexHull(corners, hull);
  const double area_fraction = cv::contourArea(hull) / (double(image_size.width) * image_size.height);
  if (area_fraction < 0.002) return str("board covers only ", 100 * area_fraction, "% of the image");
  // Every cell must turn the same way (a folded or mis-ordered grid does not), and no cell may be
  // squashed to a sliver (board seen edge-on: the homography is close to singular).
  int positive = 0, negative = 0;
  double thinnest = std::numeric_limits<double>::infinity();
  for (int r = 0; r + 1 < board.rows; ++r)
    for (int c = 0; c + 1 < board.cols; ++c) {
      const cv::Point2f a = corners[r * board.cols + c], b = corners[r * board.cols + c + 1];
      const cv::Point2f d = corners[(r + 1) * board.cols + c];
      const cv::Point2f u = b - a, v = d - a;
      const double cross = double(u.x) * v.y - double(u.y) * v.x;
      (cross > 0 ? positive : negative)++;
      const double longest = std::max(cv::norm(u), cv::norm(v));
      if (longest > 0) thinnest = std::min(thinnest, std::abs(cross) / (longest * longest));
    }
  if (positive > 0 && negative > 0) return "the detected grid folds over itself";
  if (thinnest < 0.1) return str("board seen almost edge-on (cell aspect ", thinnest, ")");
  return {};
}

namespace {

// Moves each corner to the saddle point of the image gradient, within a window fitted to the view,
// then fits the X-junction model there on the image at its full depth (16-bit and float data keep
// the precision the 8-bit copy for the detectors drops).
void refine_corners(const cv::Mat& image, const cv::Mat& gray, const BoardSpec& board, Detection& d) {
  const double square = smallest_square(d.corners, board);
  d.subpix_half_window = subpix_half_window(square);
  const int w = d.subpix_half_window;
  cv::cornerSubPix(gray, d.corners, {w, w}, {-1, -1},
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  fit_corners(to_float_gray(image), board, corner_fit_radius(square), d.corners);
}

Detection detect_sector_based(const cv::Mat& gray, const BoardSpec& board) {
  Detection d;
  d.method = "sector-based";
  d.found = cv::findChessboardCornersSB(gray, board.pattern_size(), d.corners, cv::CALIB_CB_NORMALIZE_IMAGE);
  return d;
}

Detection detect_classic(const cv::Mat& gray, const BoardSpec& board) {
  Detection d;
  d.method = "classic";
  d.found = cv::findChessboardCorners(gray, board.pattern_size(), d.corners,
                                      cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  return d;
}

}  // namespace

Detection detect_board(const cv::Mat& image, const BoardSpec& board, Detector detector) {
  const cv::Mat gray = to_gray8(image);
  Detection d;
  if (detector != Detector::classic) d = detect_sector_based(gray, board);
  if (!d.found && detector != Detector::sector_based) d = detect_classic(gray, board);
  if (!d.found || int(d.corners.size()) != board.corner_count()) {
    d.found = false;
    d.corners.clear();
    d.problem = str("no ", board.cols, "x", board.rows, " board found");
    return d;
  }
  refine_corners(image, gray, board, d);
  d.smallest_square_px = smallest_square(d.corners, board);
  if (std::string why = degeneracy(d.corners, board, gray.size()); !why.empty()) {
    d.found = false;
    d.problem = "degenerate view: " + why;
  }
  return d;
}

}  // namespace pg::calib
