#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/flow/flow.h"

namespace pg {

void FlowOptions::check() const {
  const auto require = [](bool ok, const char* field, double value, const char* rule) {
    if (!ok) throw UsageError(str("flow option ", field, " = ", value, ": ", rule));
  };
  require(alpha > 0, "alpha", alpha, "must be positive");
  require(epipolar_alpha > 0, "epipolar_alpha", epipolar_alpha, "must be positive");
  require(delta >= 0, "delta", delta, "must not be negative");
  require(gamma >= 0, "gamma", gamma, "must not be negative");
  require(delta + gamma > 0, "delta + gamma", delta + gamma, "one data term must be on");
  require(zeta >= 0, "zeta", zeta, "must not be negative");
  require(epsilon > 0, "epsilon", epsilon, "must be positive");
  require(edge_weight >= 0, "edge_weight", edge_weight, "must not be negative");
  require(epipolar_edge_weight >= 0, "epipolar_edge_weight", epipolar_edge_weight, "must not be negative");
  require(clg_rho >= 0 && clg_rho <= 20, "clg_rho", clg_rho, "must be in [0, 20]");
  require(presmooth_sigma >= 0 && presmooth_sigma <= 10, "presmooth_sigma", presmooth_sigma,
          "must be in [0, 10]");
  require(pyramid_factor >= 0.5 && pyramid_factor < 1, "pyramid_factor", pyramid_factor,
          "must be in [0.5, 1)");
  require(min_side >= 2, "min_side", min_side, "must be at least 2");
  require(max_levels >= 0, "max_levels", max_levels, "must not be negative");
  require(finest_level >= 0, "finest_level", finest_level, "must not be negative");
  require(warps >= 1 && warps <= 100, "warps", warps, "must be in [1, 100]");
  require(fixed_point_iterations >= 1 && fixed_point_iterations <= 100, "fixed_point_iterations",
          fixed_point_iterations, "must be in [1, 100]");
  require(sor_iterations >= 1 && sor_iterations <= 1000, "sor_iterations", sor_iterations,
          "must be in [1, 1000]");
  require(median_radius >= 0 && median_radius <= 2, "median_radius", median_radius, "must be 0, 1 or 2");
  require(search_range >= 0 && search_range <= 1, "search_range", search_range, "must be in [0, 1]");
  require(search_budget >= 1e4 && search_budget <= 1e9, "search_budget", search_budget,
          "must be in [1e4, 1e9]");
  require(sor_omega > 0 && sor_omega < 2, "sor_omega", sor_omega, "must be in (0, 2)");
}

FlowOptions FlowOptions::preset(const std::string& name) {
  FlowOptions options;
  if (name == "balanced") return options;
  if (name == "fast") {
    options.pyramid_factor = 0.75;
    options.finest_level = 1;
    options.fixed_point_iterations = 3;
    options.sor_iterations = 6;
    return options;
  }
  if (name == "accurate") {
    options.pyramid_factor = 0.95;
    options.sor_iterations = 25;
    return options;
  }
  throw UsageError(str("unknown flow preset '", name, "' (fast, balanced, accurate)"));
}

}  // namespace pg
