#include "pg/calib/corner_fit.h"

#include <ceres/ceres.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "pg/calib/x_junction_cost.h"

namespace pg::calib {
namespace {

struct Pixel {
  double x, y, value;
};

// Normal angle of the board line along `direction`.
double normal_angle(const cv::Point2f& direction) {
  return std::atan2(double(direction.x), -double(direction.y));
}

bool fit_corner(const cv::Mat& gray, cv::Point2f& corner, const cv::Point2f& along_row,
                const cv::Point2f& along_column, double radius) {
  std::vector<Pixel> pixels;
  const int r = int(std::ceil(radius));
  const int x0 = int(std::lround(corner.x)), y0 = int(std::lround(corner.y));
  double mean = 0;
  for (int y = y0 - r; y <= y0 + r; ++y)
    for (int x = x0 - r; x <= x0 + r; ++x) {
      if (x < 0 || y < 0 || x >= gray.cols || y >= gray.rows) continue;
      if (std::hypot(x - corner.x, y - corner.y) > radius) continue;
      pixels.push_back({double(x), double(y), double(gray.at<float>(y, x))});
      mean += pixels.back().value;
    }
  if (pixels.size() < 20) return false;
  mean /= double(pixels.size());
  double c[2] = {corner.x, corner.y};
  // shape: the two normal angles, offset, contrast (its sign says which quadrants are dark), 1 / blur.
  double shape[5] = {normal_angle(along_row), normal_angle(along_column), mean, 0, 1};
  for (const Pixel& p : pixels) {
    const double dx = p.x - c[0], dy = p.y - c[1];
    const double side = (std::cos(shape[0]) * dx + std::sin(shape[0]) * dy) *
                        (std::cos(shape[1]) * dx + std::sin(shape[1]) * dy);
    shape[3] += (p.value - mean) * (side > 0 ? 1 : -1);
  }
  shape[3] /= double(pixels.size());
  ceres::Problem problem;
  for (const Pixel& p : pixels)
    problem.AddResidualBlock(new XJunctionPixelCost(p.x, p.y, p.value), nullptr, c, shape);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 50;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable() || !std::isfinite(c[0]) || !std::isfinite(c[1])) return false;
  if (std::hypot(c[0] - corner.x, c[1] - corner.y) > 1.0) return false;
  corner = cv::Point2f(float(c[0]), float(c[1]));
  return true;
}

}  // namespace

double corner_fit_radius(double smallest_square_px) {
  return std::clamp(0.4 * smallest_square_px, 3.0, 15.0);
}

int fit_corners(const cv::Mat& gray, const BoardSpec& board, double radius,
                std::vector<cv::Point2f>& corners) {
  CV_Assert(gray.type() == CV_32FC1 && int(corners.size()) == board.corner_count());
  const std::vector<cv::Point2f> start = corners;  // neighbours' directions from the unrefined grid
  const auto at = [&](int row, int col) { return start[row * board.cols + col]; };
  std::atomic<int> refined = 0;
  // Corners are independent: the result does not depend on the thread count.
  tbb::parallel_for(0, board.corner_count(), [&](int index) {
    const int row = index / board.cols, col = index % board.cols;
    const cv::Point2f along_row = at(row, std::min(col + 1, board.cols - 1)) - at(row, std::max(col - 1, 0));
    const cv::Point2f along_column =
        at(std::min(row + 1, board.rows - 1), col) - at(std::max(row - 1, 0), col);
    refined += fit_corner(gray, corners[index], along_row, along_column, radius);
  });
  return refined;
}

}  // namespace pg::calib
