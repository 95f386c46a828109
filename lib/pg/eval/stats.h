#pragma once
// Summary statistics of an error sample, shared by every evaluation. Percentiles interpolate linearly
// between order statistics (numpy's default), so a constant sample gives that constant everywhere.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace pg {

struct ErrorStats {
  std::size_t count = 0;
  double mean = 0, median = 0, p90 = 0, p95 = 0, p99 = 0, max = 0, rms = 0;

  // {"count", "mean", "median", "p90", "p95", "p99", "max", "rms"}; the numbers are null when count is 0.
  nlohmann::json to_json() const;
};

// Sorts `values` in place and summarises them; an empty sample gives count 0 and NaN statistics.
ErrorStats summarize(std::vector<double>& values);

// The q-quantile (q in [0, 1]) of an ascending-sorted, non-empty sample.
double sorted_quantile(const std::vector<double>& sorted, double q);

// Fraction of an ascending-sorted sample that is <= threshold (0 for an empty sample).
double sorted_fraction_at_most(const std::vector<double>& sorted, double threshold);

// A finite double as itself, NaN or infinity as JSON null.
nlohmann::json json_number(double value);

}  // namespace pg
