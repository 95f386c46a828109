#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/flow/flow.h"
#include "pg/image/pyramid.h"

namespace pg {

EpipolarField epipolar_field(const Camera& from, const Camera& to) {
  if (from.width <= 0 || from.height <= 0)
    throw UsageError("epipolar_field: camera '" + from.id + "' has no size");
  const Eigen::Vector3d baseline = to.cam_from_world.centre() - from.cam_from_world.centre();
  const double scene_scale =
      std::max({1.0, from.cam_from_world.centre().norm(), to.cam_from_world.centre().norm()});
  if (baseline.norm() <= 1e-12 * scene_scale)
    throw UsageError("cameras '" + from.id + "' and '" + to.id +
                     "' share their centre: no baseline to triangulate");
  // to_from_from: X_to = R X_from + t. A point at inverse depth rho on the ray r of `from` maps to a
  // multiple of R r + rho t: rho = 0 is the point at infinity, growing rho comes nearer.
  const Rigid3 to_from_from = to.cam_from_world * from.cam_from_world.inverse();
  const Eigen::Matrix3d rotation = to_from_from.rotation_matrix();
  const Eigen::Vector3d translation = to_from_from.translation;
  const double rho_step = 1e-4 / translation.norm();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EpipolarField field;
  field.base = cv::Mat2f(from.height, from.width);
  field.direction = cv::Mat2f(from.height, from.width);
  tbb::parallel_for(tbb::blocked_range<int>(0, from.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < from.width; ++x) {
        const Eigen::Vector2d pixel(x, y);
        const Eigen::Vector3d ray = rotation * from.unproject(pixel);
        Eigen::Vector2d at_infinity, nearer;
        cv::Vec2f base(nan, nan), direction(nan, nan);
        if (to.project(ray, at_infinity) && to.project(ray + rho_step * translation, nearer)) {
          const Eigen::Vector2d along = nearer - at_infinity;
          if (along.norm() > 0 && at_infinity.allFinite()) {
            base =
                cv::Vec2f(static_cast<float>(at_infinity.x() - x), static_cast<float>(at_infinity.y() - y));
            const Eigen::Vector2d unit = along.normalized();
            direction = cv::Vec2f(static_cast<float>(unit.x()), static_cast<float>(unit.y()));
          }
        }
        field.base(y, x) = base;
        field.direction(y, x) = direction;
      }
    }
  });
  return field;
}

EpipolarField resize_epipolar_field(const EpipolarField& field, cv::Size size) {
  if (field.empty()) throw UsageError("resize_epipolar_field: empty field");
  const float scale_x = static_cast<float>(size.width) / field.base.cols;
  const float scale_y = static_cast<float>(size.height) / field.base.rows;
  std::vector<cv::Mat1f> base, direction;
  cv::split(field.base, base);
  cv::split(field.direction, direction);
  EpipolarField out;
  out.base = cv::Mat2f(size);
  out.direction = cv::Mat2f(size);
  const cv::Mat1f bx = resize_bilinear(base[0], size), by = resize_bilinear(base[1], size);
  const cv::Mat1f dx = resize_bilinear(direction[0], size), dy = resize_bilinear(direction[1], size);
  tbb::parallel_for(tbb::blocked_range<int>(0, size.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < size.width; ++x) {
        out.base(y, x) = cv::Vec2f(bx(y, x) * scale_x, by(y, x) * scale_y);
        const cv::Vec2f d(dx(y, x) * scale_x, dy(y, x) * scale_y);
        const float norm = std::hypot(d[0], d[1]);
        out.direction(y, x) = norm > 0 ? d / norm : cv::Vec2f(NAN, NAN);
      }
    }
  });
  return out;
}

}  // namespace pg
