#include "pg/sfm/sfm_outputs.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/image_io.h"
#include "pg/mesh/ply_format.h"

namespace pg {

CameraSet registered_cameras(const SfmResult& result) {
  CameraSet set;
  for (std::size_t f = 0; f < result.cameras.size(); ++f)
    if (result.registered[f]) set.cameras.push_back(result.cameras[f]);
  return set;
}

void color_points(SfmResult& result, const TrackSet& tracks) {
  // Each point takes its colour from its first observation in a registered frame; frames are read once.
  std::vector<std::vector<std::pair<int, TrackObservation>>> wanted(tracks.frames.size());
  for (std::size_t p = 0; p < result.points.size(); ++p)
    for (const TrackObservation& o : tracks.tracks[result.points[p].track].observations)
      if (result.registered[o.frame]) {
        wanted[o.frame].push_back({static_cast<int>(p), o});
        break;
      }
  for (std::size_t f = 0; f < tracks.frames.size(); ++f) {
    if (wanted[f].empty()) continue;
    cv::Mat image = read_image(tracks.frames[f].image, ReadMode::color_float);
    for (const auto& [p, o] : wanted[f]) {
      const int x = std::clamp(static_cast<int>(std::lround(o.x)), 0, image.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(o.y)), 0, image.rows - 1);
      const cv::Vec3f bgr = image.at<cv::Vec3f>(y, x);
      auto to8 = [](float v) {
        return static_cast<std::uint8_t>(std::clamp(std::lround(v * 255.0f), 0L, 255L));
      };
      result.points[p].color = {to8(bgr[2]), to8(bgr[1]), to8(bgr[0])};
    }
  }
}

void write_sparse_points(const std::filesystem::path& path, const SfmResult& result) {
  const std::size_t n = result.points.size();
  std::vector<float> xyz(3 * n), error(n), angle(n);
  std::vector<std::uint8_t> rgb(3 * n);
  std::vector<std::int32_t> length(n);
  for (std::size_t i = 0; i < n; ++i) {
    const SfmPoint& p = result.points[i];
    for (int c = 0; c < 3; ++c) {
      xyz[3 * i + c] = static_cast<float>(p.position[c]);
      rgb[3 * i + c] = p.color[c];
    }
    error[i] = static_cast<float>(p.reprojection_error_px);
    angle[i] = static_cast<float>(p.triangulation_angle_deg);
    length[i] = p.track_length;
  }
  ply::WriteRequest request;
  request.format_name = "pg-point-cloud";
  request.provenance = Provenance::current();
  request.vertex_count = n;
  using ply::Type;
  request.columns = {{"x", Type::float32, xyz.data(), 12},
                     {"y", Type::float32, xyz.data() + 1, 12},
                     {"z", Type::float32, xyz.data() + 2, 12},
                     {"red", Type::uint8, rgb.data(), 3},
                     {"green", Type::uint8, rgb.data() + 1, 3},
                     {"blue", Type::uint8, rgb.data() + 2, 3},
                     {"track_length", Type::int32, length.data(), 4},
                     {"reprojection_error", Type::float32, error.data(), 4},
                     {"triangulation_angle", Type::float32, angle.data(), 4}};
  ply::write(path, request);
}

cv::Mat render_top_view(const SfmResult& result, int size, double max_rms_px) {
  cv::Mat image(size, size, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<Eigen::Vector3d> centres;
  std::vector<int> frames;
  for (std::size_t f = 0; f < result.cameras.size(); ++f)
    if (result.registered[f])
      centres.push_back(result.cameras[f].cam_from_world.centre()), frames.push_back(int(f));
  if (centres.empty()) return image;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : centres) mean += c;
  mean /= static_cast<double>(centres.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& c : centres) cov += (c - mean) * (c - mean).transpose();
  // Axes of the view: the two largest principal directions of the camera path (for a straight path
  // the second one comes from the points).
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d u = eig.eigenvectors().col(2), v = eig.eigenvectors().col(1);
  if (eig.eigenvalues()(1) < 1e-6 * eig.eigenvalues()(2) && !result.points.empty()) {
    Eigen::Matrix3d pcov = Eigen::Matrix3d::Zero();
    for (const SfmPoint& p : result.points) pcov += (p.position - mean) * (p.position - mean).transpose();
    Eigen::Vector3d w = (pcov * Eigen::Vector3d::Ones()).normalized();
    v = (w - w.dot(u) * u).normalized();
  }
  // Extent from the cameras and the central 90% of the points.
  double extent = 0;
  for (const auto& c : centres)
    extent = std::max({extent, std::abs((c - mean).dot(u)), std::abs((c - mean).dot(v))});
  std::vector<double> radii;
  for (const SfmPoint& p : result.points)
    radii.push_back(std::max(std::abs((p.position - mean).dot(u)), std::abs((p.position - mean).dot(v))));
  if (!radii.empty()) {
    std::nth_element(radii.begin(), radii.begin() + radii.size() * 9 / 10, radii.end());
    extent = std::max(extent, radii[radii.size() * 9 / 10]);
  }
  if (extent <= 0) extent = 1;
  const double scale = 0.45 * size / extent;
  auto to_px = [&](const Eigen::Vector3d& x) {
    return cv::Point2d(size / 2.0 + scale * (x - mean).dot(u), size / 2.0 - scale * (x - mean).dot(v));
  };
  for (const SfmPoint& p : result.points) {
    const cv::Point2d q = to_px(p.position);
    if (q.x >= 0 && q.y >= 0 && q.x < size && q.y < size)
      image.at<cv::Vec3b>(static_cast<int>(q.y), static_cast<int>(q.x)) =
          cv::Vec3b(p.color[2], p.color[1], p.color[0]);
  }
  cv::Point2d previous;
  for (std::size_t i = 0; i < centres.size(); ++i) {
    const cv::Point2d q = to_px(centres[i]);
    if (i > 0) cv::line(image, previous, q, cv::Scalar(160, 160, 160), 1, cv::LINE_AA);
    previous = q;
  }
  for (std::size_t i = 0; i < centres.size(); ++i) {
    const int f = frames[i];
    const double t = std::clamp(result.frame_rms_px[f] / max_rms_px, 0.0, 1.0);
    const cv::Scalar colour(0, 200 * (1 - t), 255 * t);
    const Camera& c = result.cameras[f];
    const Eigen::Vector3d axis = c.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
    const cv::Point2d q = to_px(centres[i]);
    const cv::Point2d d(axis.dot(u), -axis.dot(v));
    cv::line(image, q, q + 15 * d, colour, 2, cv::LINE_AA);
    cv::circle(image, q, 5, colour, -1, cv::LINE_AA);
  }
  int y = 20;
  for (const std::string& id : result.unregistered) {
    cv::putText(image, "not registered: " + id, cv::Point(10, y), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 255), 1);
    y += 18;
  }
  return image;
}

double scale_to_distance(SfmResult& result, const std::string& id_a, const std::string& id_b,
                         double distance) {
  auto index_of = [&](const std::string& id) {
    for (std::size_t f = 0; f < result.cameras.size(); ++f)
      if (result.cameras[f].id == id) {
        if (!result.registered[f])
          throw FailedError(str("--scale: camera ", id, " was not registered, so it cannot set the scale"));
        return f;
      }
    throw UsageError(str("--scale: no camera ", id));
  };
  const std::size_t a = index_of(id_a), b = index_of(id_b);
  const double current =
      (result.cameras[a].cam_from_world.centre() - result.cameras[b].cam_from_world.centre()).norm();
  if (!(distance > 0)) throw UsageError("--scale: the distance is not positive");
  if (!(current > 0)) throw FailedError(str("--scale: cameras ", id_a, " and ", id_b, " coincide"));
  const double s = distance / current;
  scale_reconstruction(result, s);
  return s;
}

void scale_reconstruction(SfmResult& result, double s) {
  for (Camera& c : result.cameras) c.cam_from_world.translation *= s;
  for (SfmPoint& p : result.points) p.position *= s;
}

}  // namespace pg
