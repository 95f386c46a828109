#pragma once
// Per-pixel unit ray directions of a camera (camera frame), computed once with Camera::unproject, plus
// a direction-space lookup that turns a set of directions into the pixels whose rays can lie in it.
// The rasterizer tests every pixel ray exactly, so its only use of the camera model is this table:
// rendering is exact for every model (distortion, fisheye beyond 180 degrees, equirectangular seam and
// poles). Build it once per camera and reuse it; it depends on the intrinsics and size, not the pose.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "pg/camera/camera.h"

namespace pg {

// A pixel rectangle, inclusive bounds; x0 > x1 means empty. For cameras whose columns wrap around
// (equirectangular), x1 may exceed width - 1 (the interval continues at column 0).
struct PixelBox {
  int x0 = 1, x1 = 0, y0 = 1, y1 = 0;
  bool empty() const { return x0 > x1 || y0 > y1; }
};

class RayTable {
 public:
  RayTable() = default;
  explicit RayTable(const Camera& camera);

  int width() const { return width_; }
  int height() const { return height_; }
  bool perspective() const { return perspective_; }
  // True when column 0 continues column width - 1 (equirectangular).
  bool wraps_columns() const { return wraps_columns_; }
  // True when this table was built for a camera with the same size, model and intrinsics.
  bool matches(const Camera& camera) const;

  // Unit ray directions, row-major, one component per array (float: the inner loops vectorise).
  const float* dx() const { return dx_.data(); }
  const float* dy() const { return dy_.data(); }
  const float* dz() const { return dz_.data(); }
  Eigen::Vector3f direction(int x, int y) const {
    std::size_t i = std::size_t(y) * width_ + x;
    return {dx_[i], dy_[i], dz_[i]};
  }

  // Conservative pixel bounds of every pixel whose ray lies in the cone spanned (positively) by the
  // camera-frame points of the polygon. Returns up to two boxes with columns in [0, width) (a box that
  // crosses the equirectangular seam is split); the count is the return value.
  int pixel_boxes(const Eigen::Vector3d* polygon, int count, std::array<PixelBox, 2>& boxes) const;

 private:
  // One cube face: gnomonic coordinates (u, v) = (p[minor0], p[minor1]) / |p[major]| of the rays that
  // fall on it, binned into cells, each holding the pixel bounds of its rays.
  struct Face {
    double u0 = 0, v0 = 0, inv_cell = 1;  // grid origin and 1 / cell size
    int cols = 0, rows = 0;
    std::vector<PixelBox> cells;
  };
  struct UvRange {
    double u0, u1, v0, v1;
  };

  void build_faces();
  void add_face_range(int face, const UvRange& range, PixelBox& acc) const;
  void unite(PixelBox& acc, const PixelBox& box) const;

  int width_ = 0, height_ = 0;
  bool perspective_ = true;
  bool wraps_columns_ = false;
  CameraModel model_ = CameraModel::pinhole;
  Intrinsics intrinsics_;
  Distortion distortion_;
  std::vector<float> dx_, dy_, dz_;
  std::array<Face, 6> faces_;
};

}  // namespace pg
