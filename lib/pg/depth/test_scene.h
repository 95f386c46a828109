#pragma once
// Test helper (header only): a small analytic scene rendered by ray casting with exact depth, for the
// flow, depth and pg-depth tests. A textured sphere in front of a wall above a floor, seen by pinhole
// cameras on a horizontal arc, all looking at the sphere.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "pg/camera/camera.h"

namespace pg::depth_testing {

// Lattice value noise in [0, 1]: smooth, not periodic (periodic textures alias the correspondence).
inline double value_noise(const Eigen::Vector3d& p, std::uint32_t seed) {
  const auto hash = [seed](std::int64_t x, std::int64_t y, std::int64_t z) {
    std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
                      static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                      static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull ^ seed;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return static_cast<double>(h & 0xFFFFFF) / 0xFFFFFF;
  };
  const Eigen::Vector3d f(std::floor(p.x()), std::floor(p.y()), std::floor(p.z()));
  const Eigen::Vector3d t = p - f;
  const auto smooth = [](double v) { return v * v * (3 - 2 * v); };
  const double sx = smooth(t.x()), sy = smooth(t.y()), sz = smooth(t.z());
  const auto ix = static_cast<std::int64_t>(f.x()), iy = static_cast<std::int64_t>(f.y()),
             iz = static_cast<std::int64_t>(f.z());
  double value = 0;
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx)
        value +=
            (dx ? sx : 1 - sx) * (dy ? sy : 1 - sy) * (dz ? sz : 1 - sz) * hash(ix + dx, iy + dy, iz + dz);
  return value;
}

// Colour texture of a world point: four octaves of value noise per channel (features of 4-40 pixels
// at the test resolution).
inline cv::Vec3b texture(const Eigen::Vector3d& p) {
  cv::Vec3b colour;
  for (int c = 0; c < 3; ++c) {
    double v = 0, amplitude = 1, total = 0;
    for (double frequency : {3.0, 6.0, 12.0, 24.0}) {
      v += amplitude * value_noise(p * frequency, 17u * static_cast<std::uint32_t>(c) +
                                                      static_cast<std::uint32_t>(frequency));
      total += amplitude;
      amplitude *= 0.7;
    }
    colour[c] = static_cast<std::uint8_t>(
        std::lround(std::clamp(255.0 * (v / total - 0.5) * 2.2 + 127.5, 0.0, 255.0)));
  }
  return colour;
}

// Camera at `centre` looking at `target`, image y down, world y down.
inline Camera look_at_camera(const std::string& id, const Eigen::Vector3d& centre,
                             const Eigen::Vector3d& target, int width = 320, int height = 240,
                             double focal = 300) {
  const Eigen::Vector3d z = (target - centre).normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r.row(0) = x;
  r.row(1) = y;
  r.row(2) = z;
  Camera camera;
  camera.id = id;
  camera.width = width;
  camera.height = height;
  camera.intrinsics = {focal, focal, (width - 1) / 2.0, (height - 1) / 2.0};
  camera.cam_from_world.rotation = Eigen::Quaterniond(r);
  camera.cam_from_world.translation = -(r * centre);
  return camera;
}

struct RenderedView {
  cv::Mat3b image;
  cv::Mat1f depth;  // perspective z
};

// Ray cast: sphere (centre (0, 0.1, 4), radius 1), wall z = 7, floor y = 1.3.
inline RenderedView render(const Camera& camera) {
  RenderedView view{cv::Mat3b(camera.height, camera.width), cv::Mat1f(camera.height, camera.width)};
  const Rigid3 world_from_cam = camera.cam_from_world.inverse();
  const Eigen::Vector3d origin = camera.cam_from_world.centre();
  const Eigen::Vector3d sphere(0, 0.1, 4);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d ray_cam = camera.unproject(Eigen::Vector2d(x, y));
      const Eigen::Vector3d d = world_from_cam.rotation * ray_cam;
      double t = std::numeric_limits<double>::infinity();
      const Eigen::Vector3d oc = origin - sphere;
      const double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - 1.0);
      if (disc > 0 && -b - std::sqrt(disc) > 0) t = -b - std::sqrt(disc);
      if (d.z() > 0) t = std::min(t, (7.0 - origin.z()) / d.z());
      if (d.y() > 0) t = std::min(t, (1.3 - origin.y()) / d.y());
      const Eigen::Vector3d p = origin + t * d;
      view.image(y, x) = texture(p);
      view.depth(y, x) = static_cast<float>(t * ray_cam.z());
    }
  return view;
}

}  // namespace pg::depth_testing
