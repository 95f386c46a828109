// Camera models against OpenCV (the independent reference) and closed-form formulas.
#include "pg/camera/camera.h"

#include <gtest/gtest.h>

#include <numbers>
#include <opencv2/calib3d.hpp>
#include <random>

#include "pg/core/error.h"

namespace pg {
namespace {

constexpr double pi = std::numbers::pi;

Camera pinhole_camera() {
  Camera c;
  c.id = "pinhole";
  c.width = 1920;
  c.height = 1080;
  c.model = CameraModel::pinhole;
  c.intrinsics = {1400.5, 1398.25, 961.3, 538.7};
  // A wide lens with the rational terms active; the radial factor is monotonic over |x| < 1.
  c.distortion = {
      .k1 = -0.21, .k2 = 0.065, .p1 = 8e-4, .p2 = -4e-4, .k3 = -0.008, .k4 = 0.12, .k5 = 0.011, .k6 = 0.002};
  return c;
}

Camera fisheye_camera() {
  Camera c;
  c.id = "fisheye";
  c.width = 2048;
  c.height = 2048;
  c.model = CameraModel::fisheye;
  c.intrinsics = {640.2, 639.8, 1023.1, 1024.6};
  c.distortion = {.k1 = 0.052, .k2 = -0.011, .k3 = 0.003, .k4 = -0.0004};
  return c;
}

Camera equirect_camera() {
  Camera c;
  c.id = "pano";
  c.width = 4096;
  c.height = 2048;
  c.model = CameraModel::equirectangular;
  return c;
}

cv::Mat camera_matrix(const Camera& c) {
  return (cv::Mat_<double>(3, 3) << c.intrinsics.fx, 0, c.intrinsics.cx, 0, c.intrinsics.fy, c.intrinsics.cy,
          0, 0, 1);
}

// Points in front of the camera within `max_angle` of the optical axis, at depths 0.5..50.
std::vector<Eigen::Vector3d> random_points(std::mt19937& rng, int count, double max_angle) {
  std::uniform_real_distribution<double> angle(0, max_angle), azimuth(-pi, pi), depth(0.5, 50);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    const double theta = angle(rng), phi = azimuth(rng), range = depth(rng);
    points.emplace_back(range * std::sin(theta) * std::cos(phi), range * std::sin(theta) * std::sin(phi),
                        range * std::cos(theta));
  }
  return points;
}

std::vector<cv::Point3d> to_cv(const std::vector<Eigen::Vector3d>& points) {
  std::vector<cv::Point3d> out;
  for (const auto& p : points) out.emplace_back(p.x(), p.y(), p.z());
  return out;
}

TEST(CameraModel, NamesRoundTrip) {
  for (CameraModel m : {CameraModel::pinhole, CameraModel::fisheye, CameraModel::equirectangular})
    EXPECT_EQ(camera_model_from_string(to_string(m)), m);
  EXPECT_THROW(camera_model_from_string("orthographic"), UsageError);
}

TEST(Pinhole, ProjectMatchesOpenCvWithEightCoefficients) {
  const Camera c = pinhole_camera();
  std::mt19937 rng(11);
  const auto points = random_points(rng, 5000, 0.7);  // |x| up to tan(0.7) = 0.84
  const cv::Mat dist = (cv::Mat_<double>(1, 8) << c.distortion.k1, c.distortion.k2, c.distortion.p1,
                        c.distortion.p2, c.distortion.k3, c.distortion.k4, c.distortion.k5, c.distortion.k6);
  std::vector<cv::Point2d> reference;
  cv::projectPoints(to_cv(points), cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix(c), dist, reference);
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(c.project(points[i], pixel));
    EXPECT_NEAR(pixel.x(), reference[i].x, 1e-9);
    EXPECT_NEAR(pixel.y(), reference[i].y, 1e-9);
  }
}

TEST(Pinhole, ProjectWorldUsesThePose) {
  Camera c = pinhole_camera();
  c.cam_from_world = Rigid3::look_at({1, 2, 3}, {4, -1, 0});
  const Eigen::Vector3d world(3, 0, 1);
  Eigen::Vector2d via_world, via_camera;
  ASSERT_TRUE(c.project_world(world, via_world));
  ASSERT_TRUE(c.project(c.cam_from_world * world, via_camera));
  EXPECT_EQ(via_world, via_camera);
}

TEST(Pinhole, PointsBehindOrAtTheCentreAreNotImaged) {
  const Camera c = pinhole_camera();
  Eigen::Vector2d pixel(-1, -1);
  EXPECT_FALSE(c.project({0.1, 0.2, -1}, pixel));
  EXPECT_FALSE(c.project({0, 0, 0}, pixel));
}

TEST(Pinhole, UndistortInvertsDistort) {
  const Camera c = pinhole_camera();
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-0.85, 0.85);
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d x{u(rng), u(rng)};
    if (x.norm() > 0.85) continue;
    const Eigen::Vector2d distorted = distort_pinhole(c.distortion, x);
    EXPECT_LT((undistort_pinhole(c.distortion, distorted) - x).norm(), 1e-12) << x.transpose();
  }
  EXPECT_EQ(undistort_pinhole(Distortion{}, Eigen::Vector2d(0.3, -0.2)), Eigen::Vector2d(0.3, -0.2));
}

TEST(Pinhole, UndistortStrongBarrelToTheEdgeOfTheValidField) {
  // k1 = -0.4 alone: the radial map r (1 - 0.4 r^2) is monotonic up to r = sqrt(1 / 1.2) = 0.913.
  Distortion d;
  d.k1 = -0.4;
  for (double r = 0; r < 0.9; r += 0.01) {
    const Eigen::Vector2d x(r * 0.6, r * 0.8);
    EXPECT_LT((undistort_pinhole(d, distort_pinhole(d, x)) - x).norm(), 1e-12) << r;
  }
}

TEST(Pinhole, UnprojectInvertsProject) {
  const Camera c = pinhole_camera();
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(0, c.width - 1), v(0, c.height - 1);
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector2d pixel{u(rng), v(rng)};
    const Eigen::Vector3d ray = c.unproject(pixel);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-15);
    EXPECT_GT(ray.z(), 0);
    Eigen::Vector2d back;
    ASSERT_TRUE(c.project(3.7 * ray, back));
    EXPECT_LT((back - pixel).norm(), 1e-9);
  }
}

TEST(Fisheye, ProjectMatchesOpenCv) {
  const Camera c = fisheye_camera();
  std::mt19937 rng(14);
  const auto points = random_points(rng, 5000, 1.45);  // up to 83 degrees off-axis
  const cv::Vec4d dist(c.distortion.k1, c.distortion.k2, c.distortion.k3, c.distortion.k4);
  std::vector<cv::Point2d> reference;
  cv::fisheye::projectPoints(to_cv(points), reference, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                             camera_matrix(c), dist);
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(c.project(points[i], pixel));
    EXPECT_NEAR(pixel.x(), reference[i].x, 1e-9);
    EXPECT_NEAR(pixel.y(), reference[i].y, 1e-9);
  }
  Eigen::Vector2d centre;
  ASSERT_TRUE(c.project({0, 0, 2}, centre));
  EXPECT_EQ(centre, Eigen::Vector2d(c.intrinsics.cx, c.intrinsics.cy));
  EXPECT_FALSE(c.project({0, 0, -2}, centre));
}

TEST(Fisheye, ThetaRoundTrip) {
  const Distortion d = fisheye_camera().distortion;
  for (double theta = 0; theta < 1.5; theta += 0.001)
    EXPECT_NEAR(undistort_fisheye_theta(d, distort_fisheye_theta(d, theta)), theta, 1e-14);
}

TEST(Fisheye, UnprojectInvertsProject) {
  const Camera c = fisheye_camera();
  std::mt19937 rng(15);
  std::uniform_real_distribution<double> u(0, c.width - 1), v(0, c.height - 1);
  int tested = 0;
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector2d pixel{u(rng), v(rng)};
    const Eigen::Vector3d ray = c.unproject(pixel);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-15);
    if (ray.z() <= 0.01) continue;  // beyond the 180-degree field in the image corners
    ++tested;
    Eigen::Vector2d back;
    ASSERT_TRUE(c.project(0.8 * ray, back));
    EXPECT_LT((back - pixel).norm(), 1e-9);
  }
  EXPECT_GT(tested, 3000);
  EXPECT_EQ(c.unproject({c.intrinsics.cx, c.intrinsics.cy}), Eigen::Vector3d::UnitZ());
}

TEST(Equirectangular, ClosedFormDirections) {
  const Camera c = equirect_camera();
  const double w = c.width, h = c.height;
  struct Case {
    Eigen::Vector3d dir;
    Eigen::Vector2d pixel;
  };
  const Case cases[] = {
      {{0, 0, 1}, {w / 2 - 0.5, h / 2 - 0.5}},      // straight ahead: image centre
      {{1, 0, 0}, {3 * w / 4 - 0.5, h / 2 - 0.5}},  // right
      {{-1, 0, 0}, {w / 4 - 0.5, h / 2 - 0.5}},     // left
      {{0, 0, -1}, {w - 0.5, h / 2 - 0.5}},         // behind: the seam, lon = +pi
      {{0, -1, 0}, {w / 2 - 0.5, -0.5}},            // up: top edge
      {{0, 1, 0}, {w / 2 - 0.5, h - 0.5}},          // down: bottom edge
  };
  for (const Case& k : cases) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(c.project(2.5 * k.dir, pixel));
    EXPECT_LT((pixel - k.pixel).norm(), 1e-9) << k.dir.transpose();
  }
  std::mt19937 rng(16);
  std::normal_distribution<double> n(0, 1);
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector3d dir = Eigen::Vector3d{n(rng), n(rng), n(rng)}.normalized();
    const double lon = std::atan2(dir.x(), dir.z()), lat = std::asin(-dir.y());
    Eigen::Vector2d pixel;
    ASSERT_TRUE(c.project(dir, pixel));
    EXPECT_NEAR(pixel.x(), (lon + pi) / (2 * pi) * w - 0.5, 1e-9);
    EXPECT_NEAR(pixel.y(), (pi / 2 - lat) / pi * h - 0.5, 1e-9);
  }
  Eigen::Vector2d unused;
  EXPECT_FALSE(c.project(Eigen::Vector3d::Zero(), unused));
}

TEST(Equirectangular, UnprojectInvertsProjectIncludingSeamAndPoles) {
  const Camera c = equirect_camera();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.5, c.width - 0.5), v(-0.5, c.height - 0.5);
  std::vector<Eigen::Vector2d> pixels;
  for (int i = 0; i < 5000; ++i) pixels.push_back(Eigen::Vector2d{u(rng), v(rng)});
  for (double e : {1e-9, 1e-6, 1e-3, 0.25}) {
    pixels.emplace_back(-0.5 + e, 100.25);           // just right of the seam
    pixels.emplace_back(c.width - 0.5 - e, 100.25);  // just left of the seam
    pixels.emplace_back(1234.5, -0.5 + e);           // next to the zenith
    pixels.emplace_back(77.25, c.height - 0.5 - e);  // next to the nadir
  }
  for (const Eigen::Vector2d& pixel : pixels) {
    const Eigen::Vector3d ray = c.unproject(pixel);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-15);
    Eigen::Vector2d back;
    ASSERT_TRUE(c.project(ray, back));
    EXPECT_LT((back - pixel).norm(), 1e-9) << pixel.transpose();
  }
  // The seam column -0.5 is the same direction as width - 0.5.
  const Eigen::Vector3d left = c.unproject({-0.5, 300}), right = c.unproject({c.width - 0.5, 300});
  EXPECT_LT((left - right).norm(), 1e-15);
  Eigen::Vector2d seam;
  ASSERT_TRUE(c.project(left, seam));
  EXPECT_NEAR(seam.x(), c.width - 0.5, 1e-9);  // longitude in (-pi, pi]: the seam maps to the right edge
  // Near the pole a longitude step is a tiny angle, yet the pixel round trip holds.
  const Eigen::Vector3d zenith = c.unproject({100, -0.5});
  EXPECT_LT((zenith - Eigen::Vector3d(0, -1, 0)).norm(), 1e-15);
}

TEST(Camera, InImageAndK) {
  const Camera c = pinhole_camera();
  EXPECT_TRUE(c.in_image({-0.5, -0.5}));
  EXPECT_TRUE(c.in_image({1919.4, 1079.4}));
  EXPECT_FALSE(c.in_image({1919.5, 500}));
  EXPECT_FALSE(c.in_image({-0.6, 500}));
  EXPECT_FALSE(c.in_image({5, 500}, 10));
  EXPECT_TRUE(c.in_image({10, 500}, 10));
  const Eigen::Matrix3d k = c.K();
  const Eigen::Vector3d p(0.3, -0.2, 2);
  Distortion none;
  Camera undistorted = c;
  undistorted.distortion = none;
  Eigen::Vector2d pixel;
  ASSERT_TRUE(undistorted.project(p, pixel));
  EXPECT_LT(((k * p).hnormalized() - pixel).norm(), 1e-12);
}

// Pixel centres at integers: the centre of original pixel (u, v) is the centre of the f x f block
// starting at f u after enlarging, and a projected point lands at (x + 0.5) s - 0.5 after shrinking.
TEST(ResizedCamera, KeepsPixelCentres) {
  Camera c;
  c.width = 10;
  c.height = 8;
  c.intrinsics = {100, 100, 4.5, 3.5};
  c.distortion.k1 = -0.1;
  const Camera fine = resized_camera(c, 4);
  EXPECT_EQ(fine.width, 40);
  EXPECT_NEAR((c.unproject({2, 3}) - fine.unproject({4 * 2 + 1.5, 4 * 3 + 1.5})).norm(), 0, 1e-12);

  c.width = 640;
  c.height = 480;
  c.intrinsics = {500, 510, 319.5, 239.5};
  const Camera half = resized_camera(c, 0.5);
  EXPECT_EQ(half.width, 320);
  EXPECT_EQ(half.height, 240);
  EXPECT_DOUBLE_EQ(half.intrinsics.fx, 250);
  EXPECT_DOUBLE_EQ(half.intrinsics.fy, 255);
  EXPECT_DOUBLE_EQ(half.intrinsics.cx, 159.5);
  EXPECT_DOUBLE_EQ(half.intrinsics.cy, 119.5);
  Eigen::Vector2d full_pixel, half_pixel;
  ASSERT_TRUE(c.project(Eigen::Vector3d(0.3, -0.2, 2), full_pixel));
  ASSERT_TRUE(half.project(Eigen::Vector3d(0.3, -0.2, 2), half_pixel));
  EXPECT_NEAR(half_pixel.x(), (full_pixel.x() + 0.5) * 0.5 - 0.5, 1e-9);
  EXPECT_NEAR(half_pixel.y(), (full_pixel.y() + 0.5) * 0.5 - 0.5, 1e-9);
}

// An odd size rounds, and the intrinsics follow the sizes' actual ratio; an equirectangular camera
// only changes size (its projection depends on the size alone), and nothing shrinks below a pixel.
TEST(ResizedCamera, OddSizesEquirectangularAndTinyFactors) {
  Camera c;
  c.width = 101;
  c.height = 75;
  c.intrinsics = {90, 90, 50, 37};
  const Camera third = resized_camera(c, 1.0 / 3);
  EXPECT_EQ(third.width, 34);
  EXPECT_EQ(third.height, 25);
  EXPECT_DOUBLE_EQ(third.intrinsics.fx, 90.0 * 34 / 101);
  EXPECT_DOUBLE_EQ(third.intrinsics.fy, 90.0 * 25 / 75);
  Camera pano;
  pano.model = CameraModel::equirectangular;
  pano.width = 1024;
  pano.height = 512;
  const Camera small = resized_camera(pano, 0.5);
  EXPECT_EQ(small.width, 512);
  EXPECT_EQ(small.height, 256);
  EXPECT_EQ(small.intrinsics.fx, pano.intrinsics.fx);
  EXPECT_EQ(resized_camera(c, 1e-6).width, 1);
}

// A camera of an image stored turned: every world point lands on the turned pixel of where the
// original camera put it, with tangential distortion and an off-centre principal point.
TEST(TurnedCamera, ProjectsOntoTheTurnedPixels) {
  Camera c;
  c.width = 640;
  c.height = 480;
  c.intrinsics = {1520.4, 1525.9, 302.32, 246.87};
  c.distortion = {.k1 = -0.12, .k2 = 0.05, .p1 = 0.002, .p2 = -0.003};
  c.cam_from_world.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  c.cam_from_world.translation = {0.1, -0.2, 0.6};
  const Eigen::Vector3d world_point = c.cam_from_world.inverse() * Eigen::Vector3d(0.03, -0.02, 0.5);
  Eigen::Vector2d original;
  ASSERT_TRUE(c.project_world(world_point, original));
  for (int turns : {-1, 0, 1, 2, 3, 5}) {
    SCOPED_TRACE(turns);
    Eigen::Vector2d expected = original;
    int width = c.width;
    for (int t = 0; t < ((turns % 4) + 4) % 4; ++t) {
      expected = {expected.y(), width - 1 - expected.x()};
      width = width == c.width ? c.height : c.width;
    }
    const Camera turned = turned_camera(c, turns);
    EXPECT_EQ(turned.width, turns % 2 == 0 ? 640 : 480);
    Eigen::Vector2d pixel;
    ASSERT_TRUE(turned.project_world(world_point, pixel));
    EXPECT_NEAR((pixel - expected).norm(), 0, 1e-9);
  }
  // Turned one way and back: the same camera.
  const Camera back = turned_camera(turned_camera(c, 1), -1);
  EXPECT_NEAR(back.intrinsics.cx, c.intrinsics.cx, 1e-12);
  EXPECT_NEAR(back.cam_from_world.rotation.angularDistance(c.cam_from_world.rotation), 0, 1e-12);
  c.model = CameraModel::equirectangular;
  EXPECT_THROW(turned_camera(c, 1), UsageError);
}

}  // namespace
}  // namespace pg
