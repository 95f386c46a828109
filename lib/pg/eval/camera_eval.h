#pragma once
// Camera poses and intrinsics against ground truth. Cameras are matched by id; the estimate's centres
// are brought into the truth frame by a similarity (Umeyama, no RANSAC) before errors are measured,
// so an up-to-scale reconstruction in its own frame is evaluated fairly.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pg/camera/cameras_io.h"
#include "pg/eval/stats.h"
#include "pg/geometry/rigid.h"

namespace pg {

enum class CameraAlignment {
  similarity,  // estimate -> truth by the least-squares similarity of the camera centres
  none,        // the estimate is already in the truth frame and units (metric inputs)
};
std::string to_string(CameraAlignment alignment);
CameraAlignment camera_alignment_from_string(const std::string& name);  // throws UsageError

struct CameraEvalOptions {
  CameraAlignment alignment = CameraAlignment::similarity;
  // Ids whose centres define the alignment (empty: every matched camera). Errors are still reported
  // for every matched camera, so held-out cameras measure the alignment's generalisation.
  std::vector<std::string> align_on;
};

struct CameraError {
  std::string id;
  double centre_error = 0;           // truth units, after alignment
  double rotation_error_deg = 0;     // angle of R_estimate_aligned * R_truth^T
  double orientation_error_deg = 0;  // the same after the orientation-only alignment (orientation_error.h)
  std::optional<double> focal_relative_error;  // max(|fx/fx* - 1|, |fy/fy* - 1|)
  std::optional<double> principal_point_error_px;
};

struct CameraEvalResult {
  CameraAlignment alignment_kind = CameraAlignment::similarity;
  Sim3 alignment;                    // maps estimate world points into the truth world (identity for `none`)
  std::size_t aligned_on = 0;        // cameras the alignment was computed from
  std::vector<CameraError> cameras;  // matched cameras, in truth order
  ErrorStats centre_error, rotation_error_deg;
  // Each camera's own orientation error, free of the centre similarity's rotation error (which tilts
  // every camera alike on nearly collinear paths): see orientation_error.h.
  ErrorStats orientation_error_deg;
  ErrorStats focal_relative_error, principal_point_error_px;  // over cameras where both have intrinsics
  std::vector<std::string> missing_in_estimate;               // truth ids the estimate lacks
  std::vector<std::string> extra_in_estimate;                 // estimate ids the truth lacks

  nlohmann::json to_json() const;
  std::string to_text() const;
};

// Throws FailedError when fewer than 3 cameras are available to align on (or none match at all),
// UsageError when an `align_on` id is not a matched camera.
CameraEvalResult evaluate_cameras(const CameraSet& estimate, const CameraSet& truth,
                                  const CameraEvalOptions& options = {});

}  // namespace pg
