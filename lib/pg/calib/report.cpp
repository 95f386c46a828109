#include "pg/calib/report.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "pg/camera/camera_json.h"
#include "pg/core/log.h"
#include "pg/core/provenance.h"

namespace pg::calib {
namespace {

nlohmann::ordered_json pose_json(const Rigid3& pose) {
  const Eigen::Quaterniond& q = pose.rotation;
  return {{"rotation_wxyz", {q.w(), q.x(), q.y(), q.z()}},
          {"translation", {pose.translation.x(), pose.translation.y(), pose.translation.z()}}};
}

// Rounds px values to 1e-4 px for a readable report (far below detection accuracy).
double px(double v) {
  return std::round(v * 1e4) / 1e4;
}

// Integer drawing coordinates with 4 fractional bits for sub-pixel anti-aliased drawing.
cv::Point fixed_point(double x, double y, double scale) {
  return {int(std::lround(x * scale * 16)), int(std::lround(y * scale * 16))};
}

void legend(cv::Mat& canvas, const std::vector<std::string>& lines) {
  int y = 22;
  for (const std::string& line : lines) {
    cv::putText(canvas, line, {10, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(canvas, line, {10, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
    y += 20;
  }
}

}  // namespace

nlohmann::ordered_json camera_calibration_json(const CalibrationResult& r,
                                               const std::vector<ImageDetection>& images) {
  nlohmann::ordered_json j;
  j["camera"] = camera_to_ordered_json(r.camera);
  j["rms_px"] = r.rms;
  j["opencv_rms_px"] = r.opencv_rms;
  j["views_used"] = r.views_used;
  j["corners_used"] = r.corners_used;
  j["corners_dropped"] = r.corners_dropped;
  j["board_warp_m"] = {r.board_warp[0], r.board_warp[1]};
  nlohmann::ordered_json uncertainty = nlohmann::ordered_json::array();
  for (const ProjectionUncertainty& u : r.uncertainty)
    uncertainty.push_back(
        {{"where", u.where}, {"pixel", {u.pixel.x(), u.pixel.y()}}, {"stddev_px", u.stddev_px}});
  j["projection_uncertainty"] = uncertainty;
  nlohmann::ordered_json detections = nlohmann::ordered_json::array();
  for (const ImageDetection& d : images) {
    nlohmann::ordered_json e = {{"image", d.image}, {"found", d.detection.found}};
    if (d.detection.found) {
      e["method"] = d.detection.method;
      e["smallest_square_px"] = px(d.detection.smallest_square_px);
      e["subpix_window"] = 2 * d.detection.subpix_half_window + 1;
    } else {
      e["problem"] = d.detection.problem;
    }
    detections.push_back(e);
  }
  j["images"] = detections;
  nlohmann::ordered_json views = nlohmann::ordered_json::array();
  for (const ViewResult& v : r.views) {
    nlohmann::ordered_json e = {{"image", v.name}, {"used", v.used}, {"rms_px", v.rms}};
    if (!v.used) {
      e["dropped_reason"] = v.dropped_reason;
    } else {
      e["corners_dropped"] = v.corners_dropped;
      e["cam_from_board"] = pose_json(v.cam_from_board);
      nlohmann::ordered_json residuals = nlohmann::ordered_json::array();
      for (std::size_t k = 0; k < v.residuals.size(); ++k)
        residuals.push_back({px(v.residuals[k].x()), px(v.residuals[k].y()), v.inlier[k] ? 1 : 0});
      e["residuals"] = residuals;
    }
    views.push_back(e);
  }
  j["views"] = views;
  return j;
}

nlohmann::ordered_json calibration_report_json(const BoardSpec& board, const CalibrationOptions& o,
                                               const std::vector<nlohmann::ordered_json>& cameras,
                                               const std::optional<StereoResult>& stereo) {
  nlohmann::ordered_json j;
  j["format"] = calibration_report_format;
  j["version"] = calibration_report_version;
  j["provenance"] = to_json(Provenance::current());
  j["board"] = {{"inner_corners", {board.cols, board.rows}}, {"square_size", board.square_size}};
  j["options"] = {{"model", to_string(o.model)},
                  {"fix_aspect_ratio", o.fix_aspect_ratio},
                  {"fix_principal_point", o.fix_principal_point},
                  {"zero_tangential", o.zero_tangential},
                  {"max_view_rms", o.max_view_rms},
                  {"view_rms_factor", o.view_rms_factor},
                  {"refine", o.refine},
                  {"corner_outlier_sigmas", o.corner_outlier_sigmas},
                  {"board_warp", o.board_warp}};
  j["calibrations"] = cameras;
  if (stereo) {
    j["stereo"] = {{"second_from_first", pose_json(stereo->second_from_first)},
                   {"baseline_m", stereo->baseline},
                   {"rms_px", stereo->rms},
                   {"pairs", stereo->pairs},
                   {"reversed_orders", stereo->reversed_orders}};
  }
  return j;
}

cv::Mat draw_coverage(const CalibrationResult& result, const std::vector<ViewInput>& views,
                      const BoardSpec& board, double magnify) {
  const Camera& c = result.camera;
  const double scale = std::max(1.0, 640.0 / c.width);
  cv::Mat canvas(int(std::lround(c.height * scale)), int(std::lround(c.width * scale)), CV_8UC3,
                 cv::Scalar(40, 40, 40));
  const int outline[4] = {0, board.cols - 1, board.corner_count() - 1, (board.rows - 1) * board.cols};
  for (std::size_t i = 0; i < result.views.size(); ++i) {
    const ViewResult& v = result.views[i];
    if (!v.used) continue;
    const std::vector<cv::Point2f>& corners = views[i].corners;
    std::vector<cv::Point> polygon;
    for (int k : outline) polygon.push_back(fixed_point(corners[k].x, corners[k].y, scale));
    cv::polylines(canvas, polygon, true, cv::Scalar(110, 110, 110), 1, cv::LINE_AA, 4);
    for (std::size_t k = 0; k < corners.size(); ++k) {
      const cv::Point2f p = corners[k];
      const Eigen::Vector2d& r = v.residuals[k];
      const cv::Scalar colour = v.inlier[k] ? cv::Scalar(80, 220, 80) : cv::Scalar(60, 60, 255);
      cv::circle(canvas, fixed_point(p.x, p.y, scale), 2 * 16, cv::Scalar(200, 200, 200), -1, cv::LINE_AA, 4);
      cv::line(canvas, fixed_point(p.x, p.y, scale),
               fixed_point(p.x + magnify * r.x(), p.y + magnify * r.y(), scale), colour, 1, cv::LINE_AA, 4);
    }
  }
  legend(canvas, {str("corner coverage: ", result.views_used, " views, ", result.corners_used, " corners (",
                      result.corners_dropped, " rejected, red)"),
                  str("residuals x", magnify, ", RMS ", px(result.rms), " px")});
  return canvas;
}

cv::Mat draw_distortion(const Camera& camera) {
  const double scale = std::max(1.0, 640.0 / camera.width);
  const int width = int(std::lround(camera.width * scale)), height = int(std::lround(camera.height * scale));
  cv::Mat magnitude(height, width, CV_32FC1);
  double largest = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double m = distortion_displacement(camera, {x / scale, y / scale}).norm();
      magnitude.at<float>(y, x) = float(m);
      largest = std::max(largest, m);
    }
  cv::Mat grey, canvas;
  magnitude.convertTo(grey, CV_8U, largest > 0 ? 255.0 / largest : 0.0);
  cv::applyColorMap(grey, canvas, cv::COLORMAP_VIRIDIS);
  // Arrows from the ideal (undistorted) position to where the lens images it, longest one grid step.
  const int steps_x = 16, steps_y = 12;
  const double step = std::min(double(width) / steps_x, double(height) / steps_y);
  const double arrow_scale = largest > 0 ? 0.9 * step / largest : 0;
  for (int j = 0; j < steps_y; ++j)
    for (int i = 0; i < steps_x; ++i) {
      const Eigen::Vector2d p((i + 0.5) * width / steps_x, (j + 0.5) * height / steps_y);
      const Eigen::Vector2d d = distortion_displacement(camera, p / scale);
      cv::arrowedLine(canvas, fixed_point(p.x(), p.y(), 1),
                      fixed_point(p.x() + arrow_scale * d.x(), p.y() + arrow_scale * d.y(), 1),
                      cv::Scalar(255, 255, 255), 1, cv::LINE_AA, 4, 0.25);
    }
  legend(canvas, {str("distortion field of '", camera.id, "' (", to_string(camera.model), ")"),
                  str("largest displacement ", px(largest), " px (yellow); longest arrow = one grid step")});
  return canvas;
}

}  // namespace pg::calib
