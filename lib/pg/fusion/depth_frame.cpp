#include "pg/fusion/depth_frame.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "pg/camera/size_check.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/image_io.h"

namespace pg::fusion {
namespace {

// Camera-frame points of every pixel (NaN where the depth is invalid).
cv::Mat3f camera_points(const DepthMap& map) {
  const cv::Mat1f depth = map.depth;
  cv::Mat3f points(depth.size(), cv::Vec3f(NAN, NAN, NAN));
  tbb::parallel_for(0, depth.rows, [&](int y) {
    for (int x = 0; x < depth.cols; ++x) {
      const float d = depth(y, x);
      if (!(d > 0) || !std::isfinite(d)) continue;
      const Eigen::Vector3d ray = map.camera.unproject(Eigen::Vector2d(x, y));
      const double range = map.kind == DepthKind::perspective_z ? d / ray.z() : d;
      const Eigen::Vector3d p = ray * range;
      points(y, x) = cv::Vec3f(float(p.x()), float(p.y()), float(p.z()));
    }
  });
  return points;
}

bool valid(const cv::Vec3f& p) {
  return std::isfinite(p[0]);
}

// The normal at (x, y) from central differences of the points `reach` pixels away (falling back to
// nearer and one-sided differences). A reach of a few pixels averages out depth quantisation, which
// makes neighbour-to-neighbour normals of RGB-D sensors useless. Zero when too few points are valid.
Eigen::Vector3f normal_from_neighbours(const cv::Mat3f& points, int x, int y, int reach) {
  auto at = [&](int xx, int yy) -> const cv::Vec3f* {
    if (xx < 0 || yy < 0 || xx >= points.cols || yy >= points.rows) return nullptr;
    const cv::Vec3f& p = points(yy, xx);
    return valid(p) ? &p : nullptr;
  };
  const cv::Vec3f* c = at(x, y);
  auto difference = [&](int dx, int dy) -> Eigen::Vector3f {
    for (int r = reach; r >= 1; --r) {
      const cv::Vec3f* a = at(x + r * dx, y + r * dy);
      const cv::Vec3f* b = at(x - r * dx, y - r * dy);
      if (!a && !b) continue;
      const cv::Vec3f d = *(a ? a : c) - *(b ? b : c);
      return {d[0], d[1], d[2]};
    }
    return Eigen::Vector3f::Zero();
  };
  const Eigen::Vector3f n = difference(1, 0).cross(difference(0, 1));
  const float length = n.norm();
  return length > 0 ? Eigen::Vector3f(n / length) : Eigen::Vector3f::Zero();
}

}  // namespace

DepthFrame make_depth_frame(const DepthMap& map, const std::filesystem::path& source,
                            const WeightOptions& options, const cv::Mat& user_mask, const cv::Mat& color,
                            const std::filesystem::path& mask_source) {
  if (map.depth.empty() || map.depth.type() != CV_32FC1)
    throw InputError(source, "no single-channel float depth");
  if (map.depth.cols != map.camera.width || map.depth.rows != map.camera.height)
    throw InputError(source, str("depth is ", map.depth.cols, "x", map.depth.rows, " but its camera is ",
                                 map.camera.width, "x", map.camera.height));
  if (!user_mask.empty())
    require_mask_size(mask_source.empty() ? source : mask_source, user_mask.size(), source, map.depth.size());

  DepthFrame frame;
  frame.name = source.string();
  frame.camera = map.camera;
  frame.kind = map.kind;
  frame.depth = map.depth.clone();
  frame.weight = cv::Mat1f(map.depth.size(), 0.0f);
  frame.cos_angle = cv::Mat1f(map.depth.size(), 1.0f);
  const cv::Mat3f points = camera_points(map);

  const double quality = options.use_quality && map.camera.quality ? *map.camera.quality : 1.0;
  const double base = options.multiplier * quality;
  // Distance from the principal point to the farthest image corner (image centre for panoramas).
  const bool perspective = map.camera.is_perspective();
  const double cx = perspective ? map.camera.intrinsics.cx : (map.camera.width - 1) / 2.0;
  const double cy = perspective ? map.camera.intrinsics.cy : (map.camera.height - 1) / 2.0;
  double corner2 = 0;
  for (double x : {-0.5, map.camera.width - 0.5})
    for (double y : {-0.5, map.camera.height - 0.5})
      corner2 = std::max(corner2, (x - cx) * (x - cx) + (y - cy) * (y - cy));

  const cv::Mat1b own_mask = map.mask;
  const cv::Mat1f confidence = map.confidence;
  const cv::Mat3f normals = map.normals;
  std::vector<int> valid_rows(frame.depth.rows, 0);
  tbb::parallel_for(0, frame.depth.rows, [&](int y) {
    for (int x = 0; x < frame.depth.cols; ++x) {
      float& d = frame.depth(y, x);
      const cv::Vec3f p = points(y, x);
      if (!valid(p)) {
        d = NAN;
        continue;
      }
      const Eigen::Vector3f point(p[0], p[1], p[2]);
      const float range = point.norm();
      if (options.max_depth > 0 && (perspective ? p[2] : range) > options.max_depth) {
        d = NAN;
        continue;
      }
      ++valid_rows[y];
      if (!own_mask.empty() && own_mask(y, x) != 0) continue;
      if (!user_mask.empty() && user_mask.at<std::uint8_t>(y, x) != 0) continue;
      double w = base;
      if (options.centre_falloff > 0)
        w *= 1.0 - options.centre_falloff * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / corner2;
      Eigen::Vector3f n = Eigen::Vector3f::Zero();
      if (!normals.empty() && std::isfinite(normals(y, x)[0]))
        n = Eigen::Vector3f(normals(y, x)[0], normals(y, x)[1], normals(y, x)[2]);
      else
        n = normal_from_neighbours(points, x, y, options.normal_reach);
      const double cos_angle = n.squaredNorm() > 0 ? std::abs(n.dot(point)) / (n.norm() * range) : 1.0;
      frame.cos_angle(y, x) = float(std::max(cos_angle, min_band_cos));
      if (options.use_angle) {
        if (cos_angle < options.min_cos) continue;
        w *= cos_angle;
      }
      if (options.use_confidence && !confidence.empty()) {
        const float c = confidence(y, x);
        w *= std::isfinite(c) ? std::clamp(c, 0.0f, 1.0f) : 0.0f;
      }
      frame.weight(y, x) = float(std::max(0.0, w));
    }
  });
  std::size_t valid_count = 0;
  for (int n : valid_rows) valid_count += n;
  if (valid_count == 0)
    throw InputError(source, "the depth map holds no valid depth (all NaN, zero or beyond --max-depth)");

  if (!color.empty()) {
    cv::Mat bgr = color;
    if (bgr.depth() == CV_16U) bgr.convertTo(bgr, CV_8U, 1.0 / 257.0);
    if (bgr.depth() != CV_8U) throw InputError(source, "the colour image is not 8 or 16 bit");
    if (bgr.channels() == 1) cv::cvtColor(bgr, bgr, cv::COLOR_GRAY2BGR);
    if (bgr.channels() == 4) cv::cvtColor(bgr, bgr, cv::COLOR_BGRA2BGR);
    if (bgr.size() != frame.depth.size()) cv::resize(bgr, bgr, frame.depth.size(), 0, 0, cv::INTER_AREA);
    frame.color = bgr;
  }
  return frame;
}

void require_mask_size(const std::filesystem::path& mask_path, cv::Size mask,
                       const std::filesystem::path& source, cv::Size depth) {
  if (mask != depth)
    throw InputError(mask_path, str("mask is ", mask.width, "x", mask.height, " but the depth map ",
                                    source.string(), " is ", depth.width, "x", depth.height));
}

cv::Mat read_mask_image(const std::filesystem::path& path) {
  cv::Mat image = read_image(path, ReadMode::unchanged);
  if (image.channels() > 1) cv::extractChannel(image, image, 0);
  cv::Mat mask;
  cv::compare(image, 0, mask, cv::CMP_NE);
  return mask;
}

cv::Mat3b read_color_image(const std::filesystem::path& path) {
  cv::Mat image = read_image(path, ReadMode::unchanged);
  if (image.depth() == CV_16U) image.convertTo(image, CV_8U, 1.0 / 257.0);
  if (image.depth() != CV_8U) throw InputError(path, "colour images must be 8 or 16 bit");
  if (image.channels() == 1) cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
  return image;
}

DepthMap read_rgbd_depth(const std::filesystem::path& path, const Camera& camera, double depth_scale) {
  const cv::Mat raw = read_image(path, ReadMode::unchanged);
  if (raw.channels() != 1 || (raw.depth() != CV_16U && raw.depth() != CV_32F))
    throw InputError(path, "an RGB-D depth image must be single-channel 16-bit (PNG/PGM) or 32-bit float");
  require_camera_size(path, raw.cols, raw.rows, camera, "depth image");
  DepthMap map;
  raw.convertTo(map.depth, CV_32F, depth_scale);
  map.depth.setTo(NAN, raw == 0);
  map.kind = DepthKind::perspective_z;
  map.camera = camera;
  return map;
}

CameraSet cameras_from_pose_list(const std::filesystem::path& path, const Intrinsics& intrinsics, int width,
                                 int height) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open the pose list");
  CameraSet set;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream fields(line);
    double v[7];
    int n = 0;
    while (n < 7 && fields >> v[n]) ++n;
    if (n == 0 && fields.eof()) continue;
    std::string rest;
    if (n != 7 || (fields >> rest))
      throw InputError(path, str("line ", line_number, ": expected 7 numbers \"tx ty tz qx qy qz qw\""));
    Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (!(std::abs(q.norm() - 1) < 1e-3))
      throw InputError(path, str("line ", line_number, ": quaternion is not unit"));
    Rigid3 world_from_cam{q.normalized(), Eigen::Vector3d(v[0], v[1], v[2])};
    Camera camera;
    camera.id = std::to_string(set.cameras.size() + 1);
    camera.width = width;
    camera.height = height;
    camera.intrinsics = intrinsics;
    camera.cam_from_world = world_from_cam.inverse();
    set.cameras.push_back(camera);
    if (set.cameras.size() > 10'000'000) throw InputError(path, "too many poses");
  }
  if (set.cameras.empty()) throw InputError(path, "no poses");
  return set;
}

std::filesystem::path expand_pattern(const std::string& pattern, const std::string& id) {
  std::string result = pattern;
  for (auto at = result.find("{id}"); at != std::string::npos; at = result.find("{id}", at + id.size()))
    result.replace(at, 4, id);
  return result;
}

}  // namespace pg::fusion
