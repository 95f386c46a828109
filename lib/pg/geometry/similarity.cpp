#include "pg/geometry/similarity.h"

#include <Eigen/SVD>
#include <stdexcept>

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {

Sim3 align_similarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  if (src.size() != dst.size())
    throw std::invalid_argument(
        str("align_similarity: ", src.size(), " source points but ", dst.size(), " destination points"));
  if (src.size() < 3) throw FailedError(str("similarity alignment needs 3 or more points, got ", src.size()));
  const double n = double(src.size());
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero(), mean_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    mean_src += src[i];
    mean_dst += dst[i];
  }
  mean_src /= n;
  mean_dst /= n;

  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (1/n) sum (dst - mean)(src - mean)^T
  double variance_src = 0;
  for (std::size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d a = src[i] - mean_src;
    covariance += (dst[i] - mean_dst) * a.transpose();
    variance_src += a.squaredNorm();
  }
  covariance /= n;
  variance_src /= n;

  Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sigma = svd.singularValues();
  if (variance_src <= 0 || sigma(1) <= 1e-12 * sigma(0) || sigma(0) <= 0)
    throw FailedError("similarity alignment: the points are coincident or collinear");
  // Reflection guard: flip the weakest axis when U V^T would be a reflection.
  Eigen::Vector3d signs = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) signs(2) = -1;
  const Eigen::Matrix3d rotation = svd.matrixU() * signs.asDiagonal() * svd.matrixV().transpose();

  Sim3 s;
  s.scale = sigma.dot(signs) / variance_src;
  s.rotation = Eigen::Quaterniond(rotation).normalized();
  s.translation = mean_dst - s.scale * (rotation * mean_src);
  return s;
}

}  // namespace pg
