#pragma once
// Least-squares similarity between corresponding point sets (Umeyama 1991).
#include <Eigen/Core>
#include <vector>

#include "pg/geometry/rigid.h"

namespace pg {

// The Sim3 S minimising sum |dst_i - S * src_i|^2 (a proper rotation, positive scale). Throws
// std::invalid_argument when the sizes differ, and FailedError with fewer than 3 points or when the
// source points are collinear or coincident (the rotation is then not determined).
Sim3 align_similarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

}  // namespace pg
