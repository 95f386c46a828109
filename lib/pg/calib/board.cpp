#include "pg/calib/board.h"

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::calib {

void BoardSpec::check() const {
  if (cols < 3 || rows < 3 || cols > 100 || rows > 100)
    throw UsageError(str("board inner corners ", cols, "x", rows, " must each be in 3..100"));
  if (!(square_size > 0)) throw UsageError(str("board square size ", square_size, " must be positive"));
}

std::vector<cv::Point3f> board_points(const BoardSpec& board) {
  std::vector<cv::Point3f> points;
  points.reserve(board.corner_count());
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c < board.cols; ++c)
      points.emplace_back(float(c * board.square_size), float(r * board.square_size), 0.f);
  return points;
}

}  // namespace pg::calib
