#pragma once
// The corner fit's pixel model (see corner_fit.h) and its cost with analytic derivatives. Automatic
// differentiation of the 18 tanh per pixel took nearly all of pg-calib's time (nine tenths under the
// sanitizers); the cost computes the same model as `x_junction_model`, and the test checks its value and
// derivatives against autodiff of that function.
#include <ceres/sized_cost_function.h>

#include <cmath>

namespace pg::calib {

inline constexpr int x_junction_subsamples = 3;  // per pixel side: the model averaged over the pixel's area

// Offset + contrast * mean over pixel (x, y) of tanh(k d1) tanh(k d2), d1 and d2 the signed distances
// to the two edges through `corner`, with normals at angles shape[0] and shape[1]; shape[2] is the
// offset, shape[3] the contrast, shape[4] = k (1 / blur).
template <class T>
T x_junction_model(double x, double y, const T* corner, const T* shape) {
  using std::cos, std::sin, std::tanh;
  const T c0 = cos(shape[0]), s0 = sin(shape[0]), c1 = cos(shape[1]), s1 = sin(shape[1]);
  constexpr int n = x_junction_subsamples;
  T sum(0);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const T dx = T(x + (i + 0.5) / n - 0.5) - corner[0];
      const T dy = T(y + (j + 0.5) / n - 0.5) - corner[1];
      sum += tanh(shape[4] * (c0 * dx + s0 * dy)) * tanh(shape[4] * (c1 * dx + s1 * dy));
    }
  return shape[2] + shape[3] * sum / T(n * n);
}

// Residual model - value of one pixel; parameter blocks corner (2) and shape (5).
class XJunctionPixelCost final : public ceres::SizedCostFunction<1, 2, 5> {
 public:
  XJunctionPixelCost(double x, double y, double value) : x_(x), y_(y), value_(value) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  double x_, y_, value_;
};

}  // namespace pg::calib
