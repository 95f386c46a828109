#include "pg/fusion/depth_agreement.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>

namespace pg::fusion {

DepthAgreement depth_agreement(const TriangleBvh& mesh, const DepthFrame& frame, double tolerance) {
  const Rigid3 world_from_cam = frame.camera.cam_from_world.inverse();
  const Eigen::Vector3f centre = world_from_cam.translation.cast<float>();
  using Counts = std::pair<std::size_t, std::size_t>;
  const Counts counts = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, frame.depth.rows), Counts{0, 0},
      [&](const tbb::blocked_range<int>& rows, Counts c) {
        for (int y = rows.begin(); y < rows.end(); ++y)
          for (int x = 0; x < frame.depth.cols; ++x) {
            const float d = frame.depth(y, x);
            if (!std::isfinite(d)) continue;
            ++c.first;
            const Eigen::Vector3d ray = frame.camera.unproject(Eigen::Vector2d(x, y));
            const double range = frame.kind == DepthKind::perspective_z ? d / ray.z() : d;
            const Eigen::Vector3f direction = (world_from_cam.rotation * ray).cast<float>();
            const TriangleBvh::RayHit hit = mesh.intersect(centre, direction, float(range + tolerance));
            if (hit.hit && std::abs(hit.t - range) <= tolerance) ++c.second;
          }
        return c;
      },
      [](Counts a, Counts b) {
        return Counts{a.first + b.first, a.second + b.second};
      });
  return {counts.first, counts.second};
}

}  // namespace pg::fusion
