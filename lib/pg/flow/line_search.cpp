#include "pg/flow/line_search.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>

namespace pg::flow_detail {
namespace {

constexpr int census_radius = 3;           // 7x7 window: 48 comparisons
constexpr std::uint8_t outside_cost = 20;  // candidates falling outside `to`: neither good nor bad
constexpr int penalty_small = 8;           // SGM P1: a change of one candidate between neighbours
constexpr int penalty_large = 80;          // SGM P2: any larger change

template <class Body>
void parallel_range(int count, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, count, 4), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) body(i);
  });
}

cv::Mat1f mean_channel(const std::vector<cv::Mat1f>& channels) {
  cv::Mat1f grey = channels.front().clone();
  for (std::size_t c = 1; c < channels.size(); ++c) grey += channels[c];
  return grey * (1.0 / static_cast<double>(channels.size()));
}

struct CensusImage {
  int cols = 0;
  std::vector<std::uint64_t> bits;
  std::uint64_t operator()(int y, int x) const { return bits[static_cast<std::size_t>(y) * cols + x]; }
};

// 7x7 census: bit k set where neighbour k is brighter than the centre (borders replicated).
CensusImage census(const cv::Mat1f& image) {
  const int rows = image.rows, cols = image.cols;
  CensusImage out{cols, std::vector<std::uint64_t>(static_cast<std::size_t>(rows) * cols)};
  parallel_range(rows, [&](int y) {
    for (int x = 0; x < cols; ++x) {
      const float centre = image(y, x);
      std::uint64_t bits = 0;
      for (int dy = -census_radius; dy <= census_radius; ++dy) {
        const float* row = image[std::clamp(y + dy, 0, rows - 1)];
        for (int dx = -census_radius; dx <= census_radius; ++dx) {
          if (dx == 0 && dy == 0) continue;
          bits = (bits << 1) | (row[std::clamp(x + dx, 0, cols - 1)] > centre ? 1u : 0u);
        }
      }
      out.bits[static_cast<std::size_t>(y) * cols + x] = bits;
    }
  });
  return out;
}

// Per-pixel label range: label d means s = first(x) + d.
struct Labels {
  cv::Mat1i first;
  int count = 0;
};

Labels label_range(const cv::Mat2f& base, const cv::Mat2f& direction, int radius) {
  Labels labels;
  labels.first = cv::Mat1i(base.size());
  int count = 1;
  for (int y = 0; y < base.rows; ++y)
    for (int x = 0; x < base.cols; ++x) {
      const float foot_raw = -base(y, x).dot(direction(y, x));
      const int foot = std::isfinite(foot_raw) ? static_cast<int>(std::lround(std::max(foot_raw, 0.f))) : 0;
      const int first = std::max(0, foot - radius);
      labels.first(y, x) = first;
      count = std::max(count, foot + radius - first + 1);
    }
  labels.count = count;
  return labels;
}

// One SGM path step: the aggregated cost of `cost` given the previous pixel's aggregated costs.
inline void path_step(const std::uint8_t* cost, const std::uint16_t* previous, int previous_min, int labels,
                      std::uint16_t* out, int& out_min) {
  int best = 1 << 30;
  for (int d = 0; d < labels; ++d) {
    int value = previous[d];
    if (d > 0) value = std::min(value, previous[d - 1] + penalty_small);
    if (d + 1 < labels) value = std::min(value, previous[d + 1] + penalty_small);
    value = std::min(value, previous_min + penalty_large);
    value = cost[d] + value - previous_min;
    out[d] = static_cast<std::uint16_t>(value);
    best = std::min(best, value);
  }
  out_min = best;
}

// Occlusion handling: where several pixels land on one pixel of `to`, the one with the smaller s
// (further away) is hidden there; those pixels and the ones landing outside `to` take the background
// (the smaller s) of the nearest unoccluded pixels to their left and right on the row.
void fill_occluded(cv::Mat1f& s, const cv::Mat2f& base, const cv::Mat2f& direction) {
  const int rows = s.rows, cols = s.cols;
  cv::Mat1f nearest(rows, cols, -1.f);  // the largest s landing on each pixel of `to`
  cv::Mat1i target(rows, cols, -1);     // where each pixel lands (index), -1 = outside
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      const cv::Vec2f b = base(y, x), d = direction(y, x);
      const float px = x + b[0] + s(y, x) * d[0], py = y + b[1] + s(y, x) * d[1];
      if (!(px > -0.5f && px < cols - 0.5f && py > -0.5f && py < rows - 0.5f)) continue;
      const int tx = static_cast<int>(std::lround(px)), ty = static_cast<int>(std::lround(py));
      target(y, x) = ty * cols + tx;
      nearest(ty, tx) = std::max(nearest(ty, tx), s(y, x));
    }
  parallel_range(rows, [&](int y) {
    std::vector<char> hidden(cols);
    for (int x = 0; x < cols; ++x) {
      const int t = target(y, x);
      hidden[x] = t < 0 || s(y, x) < nearest(t / cols, t % cols) - 1.f;
    }
    std::vector<float> left(cols), right(cols);
    float last = NAN;
    for (int x = 0; x < cols; ++x) left[x] = last = hidden[x] ? last : s(y, x);
    last = NAN;
    for (int x = cols - 1; x >= 0; --x) right[x] = last = hidden[x] ? last : s(y, x);
    for (int x = 0; x < cols; ++x) {
      if (!hidden[x]) continue;
      const float a = left[x], b = right[x];
      if (std::isfinite(a) || std::isfinite(b))
        s(y, x) = std::isfinite(a) && std::isfinite(b) ? std::min(a, b) : (std::isfinite(a) ? a : b);
    }
  });
}

}  // namespace

double line_search_cost(cv::Size size, int radius) {
  return static_cast<double>(size.area()) * (2.0 * radius + 1.0);
}

cv::Mat1f search_along_lines(const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                             const cv::Mat2f& base, const cv::Mat2f& direction, int radius) {
  const int rows = base.rows, cols = base.cols;
  const CensusImage census_from = census(mean_channel(from)), census_to = census(mean_channel(to));
  const Labels labels = label_range(base, direction, radius);
  const int count = labels.count;
  const auto at = [&](int y, int x) { return (static_cast<std::size_t>(y) * cols + x) * count; };

  // Matching costs: Hamming distance of the census codes, `to` sampled at the nearest pixel.
  std::vector<std::uint8_t> cost(static_cast<std::size_t>(rows) * cols * count);
  parallel_range(rows, [&](int y) {
    for (int x = 0; x < cols; ++x) {
      std::uint8_t* c = &cost[at(y, x)];
      const cv::Vec2f b = base(y, x), dir = direction(y, x);
      const bool valid = std::isfinite(b[0]) && std::isfinite(dir[0]);
      for (int d = 0; d < count; ++d) {
        const float s = static_cast<float>(labels.first(y, x) + d);
        const int px = valid ? static_cast<int>(std::lround(x + b[0] + s * dir[0])) : -1;
        const int py = valid ? static_cast<int>(std::lround(y + b[1] + s * dir[1])) : -1;
        c[d] = px >= 0 && px < cols && py >= 0 && py < rows
                   ? static_cast<std::uint8_t>(std::popcount(census_from(y, x) ^ census_to(py, px)))
                   : outside_cost;
      }
    }
  });

  // Aggregation over 8 paths into `total`. Horizontal paths run row by row in parallel; the three
  // downward (then upward) paths advance one row at a time, parallel along the row.
  std::vector<std::uint16_t> total(cost.size(), 0);
  parallel_range(rows, [&](int y) {
    std::vector<std::uint16_t> previous(count), current(count);
    for (const int step : {1, -1}) {
      int previous_min = 0;
      std::fill(previous.begin(), previous.end(), 0);
      for (int i = 0; i < cols; ++i) {
        const int x = step > 0 ? i : cols - 1 - i;
        int current_min = 0;
        path_step(&cost[at(y, x)], previous.data(), previous_min, count, current.data(), current_min);
        std::uint16_t* t = &total[at(y, x)];
        for (int d = 0; d < count; ++d) t[d] += current[d];
        std::swap(previous, current);
        previous_min = current_min;
      }
    }
  });
  const std::size_t row_size = static_cast<std::size_t>(cols) * count;
  for (const int step : {1, -1}) {
    // previous[k]: the aggregated costs of the last row along direction k (dx = k - 1).
    std::vector<std::vector<std::uint16_t>> previous(3, std::vector<std::uint16_t>(row_size, 0));
    std::vector<std::vector<std::uint16_t>> current = previous;
    std::vector<std::vector<int>> previous_min(3, std::vector<int>(cols, 0)), current_min = previous_min;
    const std::vector<std::uint16_t> zeros(count, 0);  // before the first pixel of a path
    for (int i = 0; i < rows; ++i) {
      const int y = step > 0 ? i : rows - 1 - i;
      parallel_range(cols, [&](int x) {
        std::uint16_t* t = &total[at(y, x)];
        for (int k = 0; k < 3; ++k) {
          const int xp = std::clamp(x - (k - 1), 0, cols - 1);
          const bool first = i == 0 || xp != x - (k - 1);
          const std::uint16_t* prev =
              first ? zeros.data() : &previous[k][static_cast<std::size_t>(xp) * count];
          const int prev_min = first ? 0 : previous_min[k][xp];
          std::uint16_t* out = &current[k][static_cast<std::size_t>(x) * count];
          path_step(&cost[at(y, x)], prev, prev_min, count, out, current_min[k][x]);
          for (int d = 0; d < count; ++d) t[d] += out[d];
        }
      });
      std::swap(previous, current);
      std::swap(previous_min, current_min);
    }
  }

  // Winner take all with a parabola through the neighbouring candidates.
  cv::Mat1f s(rows, cols);
  parallel_range(rows, [&](int y) {
    for (int x = 0; x < cols; ++x) {
      const std::uint16_t* t = &total[at(y, x)];
      const int best = static_cast<int>(std::min_element(t, t + count) - t);
      float offset = 0;
      if (best > 0 && best + 1 < count) {
        const float left = t[best - 1], centre = t[best], right = t[best + 1];
        const float curvature = left - 2 * centre + right;
        if (curvature > 0) offset = std::clamp(0.5f * (left - right) / curvature, -0.5f, 0.5f);
      }
      s(y, x) = static_cast<float>(labels.first(y, x) + best) + offset;
    }
  });
  cv::Mat1f filtered;
  cv::medianBlur(s, filtered, 5);
  fill_occluded(filtered, base, direction);
  return filtered;
}

}  // namespace pg::flow_detail
