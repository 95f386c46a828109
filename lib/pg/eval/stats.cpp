#include "pg/eval/stats.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pg {

nlohmann::json json_number(double value) {
  if (!std::isfinite(value)) return nullptr;
  return value;
}

nlohmann::json ErrorStats::to_json() const {
  return {{"count", count},          {"mean", json_number(mean)}, {"median", json_number(median)},
          {"p90", json_number(p90)}, {"p95", json_number(p95)},   {"p99", json_number(p99)},
          {"max", json_number(max)}, {"rms", json_number(rms)}};
}

double sorted_quantile(const std::vector<double>& sorted, double q) {
  double position = std::clamp(q, 0.0, 1.0) * double(sorted.size() - 1);
  auto below = std::size_t(position);
  if (below + 1 >= sorted.size()) return sorted.back();
  double t = position - double(below);
  return sorted[below] + t * (sorted[below + 1] - sorted[below]);
}

double sorted_fraction_at_most(const std::vector<double>& sorted, double threshold) {
  if (sorted.empty()) return 0;
  auto end = std::upper_bound(sorted.begin(), sorted.end(), threshold);
  return double(end - sorted.begin()) / double(sorted.size());
}

ErrorStats summarize(std::vector<double>& values) {
  ErrorStats s;
  s.count = values.size();
  if (values.empty()) {
    double nan = std::numeric_limits<double>::quiet_NaN();
    s.mean = s.median = s.p90 = s.p95 = s.p99 = s.max = s.rms = nan;
    return s;
  }
  std::sort(values.begin(), values.end());
  double sum = 0, sum_squares = 0;
  for (double v : values) {
    sum += v;
    sum_squares += v * v;
  }
  s.mean = sum / double(values.size());
  s.rms = std::sqrt(sum_squares / double(values.size()));
  s.median = sorted_quantile(values, 0.5);
  s.p90 = sorted_quantile(values, 0.90);
  s.p95 = sorted_quantile(values, 0.95);
  s.p99 = sorted_quantile(values, 0.99);
  s.max = values.back();
  return s;
}

}  // namespace pg
