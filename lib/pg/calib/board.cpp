#include "pg/calib/board.h"

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::calib {

void BoardSpec::check() const {
  if (cols < 3 || rows < 3 || cols > 100 || rows > 100)
    throw UsageError(str("board inner corners ", cols, "x", rows, " must each be in 3..100"));
  if (!(square_size > 0)) throw UsageError(str("board square size ", square_size, " must be positive"));
}

BoardSpec parse_board(const std::string& text, double square) {
  BoardSpec board;
  const auto x = text.find('x');
  try {
    if (x == std::string::npos) throw std::invalid_argument("");
    std::size_t used = 0;
    board.cols = std::stoi(text.substr(0, x), &used);
    board.rows = std::stoi(text.substr(x + 1));
  } catch (const std::exception&) {
    throw UsageError("board \"" + text + "\" must be inner corners as COLSxROWS, e.g. 9x6");
  }
  board.square_size = square;
  board.check();
  return board;
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
