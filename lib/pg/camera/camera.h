#pragma once
// Camera models (formats/cameras.md): pinhole with OpenCV radial-tangential distortion (k1..k6, p1, p2),
// fisheye (equidistant, k1..k4, as OpenCV's cv::fisheye), and equirectangular (longitude across,
// latitude down). Frame: x right, y down, z forward; pixel (0,0) is the centre of the top-left pixel.
#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

#include "pg/geometry/rigid.h"

namespace pg {

enum class CameraModel { pinhole, fisheye, equirectangular };
std::string to_string(CameraModel model);
CameraModel camera_model_from_string(const std::string& name);  // throws UsageError

struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// pinhole: k1 k2 p1 p2 k3 k4 k5 k6 (OpenCV order); fisheye: k1 k2 k3 k4 (others zero).
struct Distortion {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0, k4 = 0, k5 = 0, k6 = 0;
  bool is_zero() const {
    return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0 && k4 == 0 && k5 == 0 && k6 == 0;
  }
};

struct Camera {
  std::string id;
  std::string image;  // image path, relative to the cameras file's folder unless absolute
  int width = 0, height = 0;
  CameraModel model = CameraModel::pinhole;
  Intrinsics intrinsics;  // unused for equirectangular
  Distortion distortion;
  Rigid3 cam_from_world;
  std::optional<double> quality;   // optional per-camera tracking quality in [0, 1]
  std::optional<std::string> rig;  // rig id this camera belongs to
  // Standard deviations of the calibrated parameters, when known (pg-calib fills these).
  std::optional<std::array<double, 12>> stddev;  // fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6

  // Camera-frame point -> pixel. Returns false if the point cannot be imaged (behind a perspective
  // camera, or at the origin); pixel is still written when finite. Does not check image bounds.
  bool project(const Eigen::Vector3d& point_cam, Eigen::Vector2d& pixel) const;
  // Pixel -> unit-length ray direction in the camera frame (z > 0 for perspective models).
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;
  // World point -> pixel, through cam_from_world.
  bool project_world(const Eigen::Vector3d& point_world, Eigen::Vector2d& pixel) const;
  // Whether the pixel lies in [-0.5 + margin, width - 0.5 - margin) x [-0.5 + margin, height - 0.5 - margin).
  bool in_image(const Eigen::Vector2d& pixel, double margin = 0) const;
  bool is_perspective() const { return model != CameraModel::equirectangular; }
  Eigen::Matrix3d K() const;
};

// Normalised-plane distortion of the pinhole model: (x, y) undistorted -> distorted, and its inverse
// (iterative, accurate to 1e-12 within the model's valid field).
Eigen::Vector2d distort_pinhole(const Distortion& d, const Eigen::Vector2d& undistorted);
Eigen::Vector2d undistort_pinhole(const Distortion& d, const Eigen::Vector2d& distorted);
// Fisheye (equidistant): camera-frame ray angle theta -> distorted radius theta_d, and inverse.
double distort_fisheye_theta(const Distortion& d, double theta);
double undistort_fisheye_theta(const Distortion& d, double theta_d);

// Equirectangular (formats/conventions.md): lon = atan2(x, z) in (-pi, pi], 0 straight ahead (+z),
// increasing towards +x; lat = asin(-y) in [-pi/2, pi/2], +pi/2 straight up (-y, since y is down).
// u = (lon + pi) / (2 pi) * width - 0.5,  v = (pi/2 - lat) / pi * height - 0.5: the seam (lon = +-pi,
// looking backwards) is the left/right image edge, the top row looks up, the bottom row down.
Eigen::Vector2d equirect_pixel_from_direction(int width, int height, const Eigen::Vector3d& dir);
Eigen::Vector3d equirect_direction_from_pixel(int width, int height, const Eigen::Vector2d& pixel);

// The camera of its images resized by `factor`: the size rounded (at least 1 pixel), pinhole and
// fisheye intrinsics scaled by the sizes' actual ratio with pixel centres kept consistent
// (c' = (c + 0.5) s - 0.5); an equirectangular camera only changes size.
Camera resized_camera(const Camera& camera, double factor);

// The camera of its images turned `quarter_turns` times 90 degrees counter-clockwise (negative:
// clockwise), as an image stored rotated from the frame its calibration describes: pixel (x, y) of a
// W-wide image lands on (y, W - 1 - x) per turn, and the pose turns with the image, so every world
// point projects to the turned pixel. Throws UsageError for an equirectangular camera.
Camera turned_camera(const Camera& camera, int quarter_turns);

}  // namespace pg
