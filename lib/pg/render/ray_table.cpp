#include "pg/render/ray_table.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"

namespace pg {
namespace {

// Directions within this relative distance of a cube-face boundary are treated as possibly on either
// side, and uv ranges are widened by it: it covers float rounding in the per-pixel test (~1e-6 rad).
constexpr double kFaceMargin = 1e-5;
constexpr int kMaxGridSide = 8192;
constexpr PixelBox kNoPixels{std::numeric_limits<int>::max(), std::numeric_limits<int>::min(),
                             std::numeric_limits<int>::max(), std::numeric_limits<int>::min()};

struct FaceAxes {
  int major, minor0, minor1;
  double sign;
};

FaceAxes face_axes(int face) {
  int a = face / 2;
  return {a, (a + 1) % 3, (a + 2) % 3, face % 2 == 0 ? 1.0 : -1.0};
}

int face_of(const Eigen::Vector3d& d) {
  Eigen::Vector3d a = d.cwiseAbs();
  int axis = a.x() >= a.y() && a.x() >= a.z() ? 0 : (a.y() >= a.z() ? 1 : 2);
  return 2 * axis + (d[axis] < 0 ? 1 : 0);
}

// True when p lies strictly inside face f's cone, away from its boundary by the margin.
bool well_inside(const Eigen::Vector3d& p, const FaceAxes& f) {
  double major = f.sign * p[f.major];
  return major > 0 && major * (1 - kFaceMargin) >= std::max(std::abs(p[f.minor0]), std::abs(p[f.minor1]));
}

// Sutherland-Hodgman clip of a convex polygon to {p : dot(plane, p) >= 0}.
int clip(const Eigen::Vector3d* in, int n, const Eigen::Vector3d& plane, Eigen::Vector3d* out) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d& a = in[i];
    const Eigen::Vector3d& b = in[(i + 1) % n];
    double da = plane.dot(a), db = plane.dot(b);
    if (da >= 0) out[m++] = a;
    if ((da >= 0) != (db >= 0)) out[m++] = a + (b - a) * (da / (da - db));
  }
  return m;
}

}  // namespace

RayTable::RayTable(const Camera& camera)
    : width_(camera.width),
      height_(camera.height),
      perspective_(camera.is_perspective()),
      wraps_columns_(camera.model == CameraModel::equirectangular),
      model_(camera.model),
      intrinsics_(camera.intrinsics),
      distortion_(camera.distortion) {
  if (width_ <= 0 || height_ <= 0 || std::int64_t(width_) * height_ > (std::int64_t{1} << 28))
    throw UsageError(str("camera \"", camera.id, "\": cannot render a ", width_, "x", height_, " image"));
  std::size_t n = std::size_t(width_) * height_;
  dx_.resize(n);
  dy_.resize(n);
  dz_.resize(n);
  parallel_chunks(height_, 16, [&](std::int64_t y0, std::int64_t y1) {
    for (std::int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < width_; ++x) {
        Eigen::Vector3d d = camera.unproject(Eigen::Vector2d(x, double(y)));
        std::size_t i = std::size_t(y) * width_ + x;
        dx_[i] = float(d.x());
        dy_[i] = float(d.y());
        dz_[i] = float(d.z());
      }
  });
  build_faces();
}

bool RayTable::matches(const Camera& camera) const {
  const Intrinsics& k = camera.intrinsics;
  const Distortion& d = camera.distortion;
  const Distortion& e = distortion_;
  return camera.width == width_ && camera.height == height_ && camera.model == model_ &&
         k.fx == intrinsics_.fx && k.fy == intrinsics_.fy && k.cx == intrinsics_.cx &&
         k.cy == intrinsics_.cy && d.k1 == e.k1 && d.k2 == e.k2 && d.p1 == e.p1 && d.p2 == e.p2 &&
         d.k3 == e.k3 && d.k4 == e.k4 && d.k5 == e.k5 && d.k6 == e.k6;
}

void RayTable::build_faces() {
  auto pixel_direction = [&](std::size_t i) { return Eigen::Vector3d(dx_[i], dy_[i], dz_[i]); };
  auto valid = [](const Eigen::Vector3d& d) { return d.allFinite() && d.squaredNorm() > 0.5; };
  std::size_t n = dx_.size();

  // Pass 1: the uv bounds and ray count of each face.
  std::array<UvRange, 6> range;
  std::array<std::size_t, 6> count{};
  range.fill({std::numeric_limits<double>::max(), -std::numeric_limits<double>::max(),
              std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()});
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d d = pixel_direction(i);
    if (!valid(d)) continue;
    int f = face_of(d);
    FaceAxes a = face_axes(f);
    double m = std::abs(d[a.major]), u = d[a.minor0] / m, v = d[a.minor1] / m;
    range[f] = {std::min(range[f].u0, u), std::max(range[f].u1, u), std::min(range[f].v0, v),
                std::max(range[f].v1, v)};
    ++count[f];
  }
  // Pass 2: a grid with about one cell per ray on each face.
  for (int f = 0; f < 6; ++f) {
    Face& face = faces_[f];
    face = Face{};
    if (count[f] == 0) continue;
    double su = range[f].u1 - range[f].u0, sv = range[f].v1 - range[f].v0;
    // About one cell per ray: finer cells tighten the boxes but cost more in the cell loop (measured).
    double cell = std::sqrt(su * sv / double(count[f]));
    cell = std::max({cell, su / kMaxGridSide, sv / kMaxGridSide, 1e-12});
    face.u0 = range[f].u0;
    face.v0 = range[f].v0;
    face.inv_cell = 1.0 / cell;
    face.cols = std::min(kMaxGridSide, int(su * face.inv_cell) + 1);
    face.rows = std::min(kMaxGridSide, int(sv * face.inv_cell) + 1);
    // Empty cells hold inverted infinite bounds, so uniting boxes without wrap is plain min / max.
    face.cells.assign(std::size_t(face.cols) * face.rows, kNoPixels);
  }
  // Pass 3: each cell's pixel bounds.
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d d = pixel_direction(i);
    if (!valid(d)) continue;
    int f = face_of(d);
    FaceAxes a = face_axes(f);
    const Face& face = faces_[f];
    double m = std::abs(d[a.major]);
    int cu = std::clamp(int((d[a.minor0] / m - face.u0) * face.inv_cell), 0, face.cols - 1);
    int cv = std::clamp(int((d[a.minor1] / m - face.v0) * face.inv_cell), 0, face.rows - 1);
    int x = int(i % width_), y = int(i / width_);
    unite(faces_[f].cells[std::size_t(cv) * face.cols + cu], PixelBox{x, x, y, y});
  }
}

void RayTable::unite(PixelBox& acc, const PixelBox& box) const {
  if (box.empty()) return;
  if (acc.empty()) {
    acc = box;
    return;
  }
  acc.y0 = std::min(acc.y0, box.y0);
  acc.y1 = std::max(acc.y1, box.y1);
  if (!wraps_columns_) {
    acc.x0 = std::min(acc.x0, box.x0);
    acc.x1 = std::max(acc.x1, box.x1);
    return;
  }
  // Circular union: shift the new interval by a whole turn where that gives the shorter union.
  int w = width_;
  if (acc.x1 - acc.x0 + 1 >= w) return;
  int best_x0 = 0, best_x1 = std::numeric_limits<int>::max();
  for (int shift : {0, -w, w}) {
    int x0 = std::min(acc.x0, box.x0 + shift), x1 = std::max(acc.x1, box.x1 + shift);
    if (x1 - x0 < best_x1 - best_x0) best_x0 = x0, best_x1 = x1;
  }
  if (best_x1 - best_x0 + 1 >= w) {
    acc.x0 = 0, acc.x1 = w - 1;
    return;
  }
  if (best_x0 < 0) best_x0 += w, best_x1 += w;
  if (best_x0 >= w) best_x0 -= w, best_x1 -= w;
  acc.x0 = best_x0;
  acc.x1 = best_x1;
}

void RayTable::add_face_range(int f, const UvRange& r, PixelBox& acc) const {
  const Face& face = faces_[f];
  if (face.cells.empty()) return;
  double cu0 = (r.u0 - kFaceMargin - face.u0) * face.inv_cell,
         cu1 = (r.u1 + kFaceMargin - face.u0) * face.inv_cell;
  double cv0 = (r.v0 - kFaceMargin - face.v0) * face.inv_cell,
         cv1 = (r.v1 + kFaceMargin - face.v0) * face.inv_cell;
  if (!(cu1 >= 0 && cv1 >= 0 && cu0 < face.cols && cv0 < face.rows)) return;  // also rejects NaN
  int i0 = int(std::max(cu0, 0.0)), i1 = int(std::min(cu1, face.cols - 1.0));
  int j0 = int(std::max(cv0, 0.0)), j1 = int(std::min(cv1, face.rows - 1.0));
  if (wraps_columns_) {
    for (int j = j0; j <= j1; ++j) {
      const PixelBox* row = &face.cells[std::size_t(j) * face.cols];
      for (int i = i0; i <= i1; ++i) unite(acc, row[i]);
    }
    return;
  }
  PixelBox box = kNoPixels;
  for (int j = j0; j <= j1; ++j) {
    const PixelBox* row = &face.cells[std::size_t(j) * face.cols];
    for (int i = i0; i <= i1; ++i) {
      box.x0 = std::min(box.x0, row[i].x0);
      box.x1 = std::max(box.x1, row[i].x1);
      box.y0 = std::min(box.y0, row[i].y0);
      box.y1 = std::max(box.y1, row[i].y1);
    }
  }
  unite(acc, box);
}

int RayTable::pixel_boxes(const Eigen::Vector3d* polygon, int count, std::array<PixelBox, 2>& boxes) const {
  PixelBox acc;
  auto project_range = [](const Eigen::Vector3d* p, int n, const FaceAxes& a) {
    UvRange r{std::numeric_limits<double>::max(), -std::numeric_limits<double>::max(),
              std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()};
    for (int i = 0; i < n; ++i) {
      double m = a.sign * p[i][a.major];
      // A point at the camera centre: the polygon touches the centre and may cover the whole face.
      if (!(m > 1e-300)) return UvRange{-2, 2, -2, 2};
      double u = p[i][a.minor0] / m, v = p[i][a.minor1] / m;
      r = {std::min(r.u0, u), std::max(r.u1, u), std::min(r.v0, v), std::max(r.v1, v)};
    }
    return r;
  };

  int f0 = face_of(polygon[0]);
  FaceAxes a0 = face_axes(f0);
  bool single_face = true;
  for (int i = 0; i < count && single_face; ++i) single_face = well_inside(polygon[i], a0);
  if (single_face) {
    add_face_range(f0, project_range(polygon, count, a0), acc);
  } else {
    for (int f = 0; f < 6; ++f) {
      if (faces_[f].cells.empty()) continue;
      FaceAxes a = face_axes(f);
      std::array<Eigen::Vector3d, 16> buf0, buf1;
      int n = std::min(count, 8);
      std::copy(polygon, polygon + n, buf0.begin());
      // Keep {sign * p[major] * (1 + margin) >= +-p[minor]}: the face's cone, slightly widened.
      for (int minor : {a.minor0, a.minor1})
        for (double side : {1.0, -1.0}) {
          Eigen::Vector3d plane = Eigen::Vector3d::Zero();
          plane[a.major] = a.sign * (1 + kFaceMargin);
          plane[minor] = -side;
          n = clip(buf0.data(), n, plane, buf1.data());
          std::copy(buf1.begin(), buf1.begin() + n, buf0.begin());
        }
      if (n > 0) add_face_range(f, project_range(buf0.data(), n, a), acc);
    }
  }
  if (acc.empty()) return 0;
  boxes[0] = acc;
  if (acc.x1 < width_) return 1;
  boxes[0].x1 = width_ - 1;
  boxes[1] = {0, acc.x1 - width_, acc.y0, acc.y1};
  return 2;
}

}  // namespace pg
