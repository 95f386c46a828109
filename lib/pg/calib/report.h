#pragma once
// The calibration report (formats/calibration-report.md) and its two pictures.
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pg/calib/calibrate.h"
#include "pg/calib/detect.h"
#include "pg/calib/stereo.h"

namespace pg::calib {

inline constexpr const char* calibration_report_format = "pg-calibration-report";
inline constexpr int calibration_report_version = 1;

// What detection said about one input image.
struct ImageDetection {
  std::string image;
  Detection detection;
};

// One calibrated camera's part of the report.
nlohmann::ordered_json camera_calibration_json(const CalibrationResult& result,
                                               const std::vector<ImageDetection>& images);

// The whole report: format header and provenance, board, options, one entry per camera, stereo.
nlohmann::ordered_json calibration_report_json(const BoardSpec& board, const CalibrationOptions& options,
                                               const std::vector<nlohmann::ordered_json>& cameras,
                                               const std::optional<StereoResult>& stereo);

// Every used view's board outline and corners over the frame, residual vectors magnified (inliers
// green, rejected corners red), with a legend. Same size as the image (at least 640 wide).
cv::Mat draw_coverage(const CalibrationResult& result, const std::vector<ViewInput>& views,
                      const BoardSpec& board, double magnify = 100);

// The distortion field: displacement magnitude as a colour map with arrows on a grid, and a legend.
cv::Mat draw_distortion(const Camera& camera);

}  // namespace pg::calib
