#include "pg/fusion/depth_agreement.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>

namespace pg::fusion {

DepthAgreement depth_agreement(const TriangleBvh& mesh, const DepthFrame& frame, double tolerance) {
  const Rigid3 world_from_cam = frame.camera.cam_from_world.inverse();
  const Eigen::Vector3f centre = world_from_cam.translation.cast<float>();
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, frame.depth.rows), DepthAgreement{},
      [&](const tbb::blocked_range<int>& rows, DepthAgreement c) {
        for (int y = rows.begin(); y < rows.end(); ++y)
          for (int x = 0; x < frame.depth.cols; ++x) {
            const float d = frame.depth(y, x);
            if (!std::isfinite(d)) continue;
            ++c.valid_pixels;
            const Eigen::Vector3d ray = frame.camera.unproject(Eigen::Vector2d(x, y));
            const double range = frame.kind == DepthKind::perspective_z ? d / ray.z() : d;
            const Eigen::Vector3f direction = (world_from_cam.rotation * ray).cast<float>();
            const TriangleBvh::RayHit hit = mesh.intersect(centre, direction, float(range + tolerance));
            if (!hit.hit)
              ++c.missed;
            else if (hit.t < range - tolerance)
              ++c.in_front;
            else
              ++c.agreeing;
          }
        return c;
      },
      [](DepthAgreement a, const DepthAgreement& b) { return a += b; });
}

}  // namespace pg::fusion
