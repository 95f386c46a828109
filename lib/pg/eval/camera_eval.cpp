#include "pg/eval/camera_eval.h"

#include "pg/eval/orientation_error.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/eval/orientation_error.h"
#include "pg/geometry/similarity.h"

namespace pg {
namespace {

// Angle of a rotation given as a quaternion, accurate for small angles (unlike acos of the trace).
double rotation_angle_deg(const Eigen::Quaterniond& q) {
  double angle = 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
  return angle * 180.0 / std::numbers::pi;
}

bool has_intrinsics(const Camera& c) {
  return c.is_perspective() && c.intrinsics.fx > 0 && c.intrinsics.fy > 0;
}

// Intrinsics of `estimate` compared with `truth`; an estimate at another resolution is rescaled first.
void compare_intrinsics(const Camera& estimate, const Camera& truth, CameraError& error) {
  if (!has_intrinsics(estimate) || !has_intrinsics(truth)) return;
  double scale = (estimate.width > 0 && truth.width > 0) ? double(truth.width) / estimate.width : 1.0;
  const Intrinsics& e = estimate.intrinsics;
  const Intrinsics& t = truth.intrinsics;
  error.focal_relative_error =
      std::max(std::abs(scale * e.fx / t.fx - 1.0), std::abs(scale * e.fy / t.fy - 1.0));
  // Pixel centres sit at integers, so a resolution change maps c to (c + 0.5) * scale - 0.5.
  Eigen::Vector2d ce((e.cx + 0.5) * scale - 0.5, (e.cy + 0.5) * scale - 0.5);
  error.principal_point_error_px = (ce - Eigen::Vector2d(t.cx, t.cy)).norm();
}

}  // namespace

std::string to_string(CameraAlignment alignment) {
  return alignment == CameraAlignment::similarity ? "similarity" : "none";
}

CameraAlignment camera_alignment_from_string(const std::string& name) {
  if (name == "similarity") return CameraAlignment::similarity;
  if (name == "none") return CameraAlignment::none;
  throw UsageError(str("unknown camera alignment '", name, "' (expected similarity or none)"));
}

CameraEvalResult evaluate_cameras(const CameraSet& estimate, const CameraSet& truth,
                                  const CameraEvalOptions& options) {
  CameraEvalResult result;
  result.alignment_kind = options.alignment;

  std::vector<std::pair<const Camera*, const Camera*>> matched;  // (estimate, truth)
  std::set<std::string> truth_ids;
  for (const Camera& t : truth.cameras) {
    truth_ids.insert(t.id);
    if (const Camera* e = estimate.find(t.id))
      matched.emplace_back(e, &t);
    else
      result.missing_in_estimate.push_back(t.id);
  }
  for (const Camera& e : estimate.cameras)
    if (!truth_ids.count(e.id)) result.extra_in_estimate.push_back(e.id);
  if (matched.empty()) throw FailedError("no camera id is shared by the estimate and the truth");

  if (options.alignment == CameraAlignment::similarity) {
    std::set<std::string> wanted(options.align_on.begin(), options.align_on.end());
    for (const std::string& id : wanted)
      if (std::none_of(matched.begin(), matched.end(), [&](const auto& m) { return m.second->id == id; }))
        throw UsageError(str("camera '", id, "' to align on is not in both the estimate and the truth"));
    std::vector<Eigen::Vector3d> src, dst;
    for (const auto& [e, t] : matched) {
      if (!wanted.empty() && !wanted.count(t->id)) continue;
      src.push_back(e->cam_from_world.centre());
      dst.push_back(t->cam_from_world.centre());
    }
    if (src.size() < 3)
      throw FailedError(str("a similarity alignment needs at least 3 matched cameras, got ", src.size()));
    result.alignment = align_similarity(src, dst);
    result.aligned_on = src.size();
  }

  std::vector<double> centre, rotation, focal, principal;
  for (const auto& [e, t] : matched) {
    CameraError error;
    error.id = t->id;
    Eigen::Vector3d aligned_centre = result.alignment * e->cam_from_world.centre();
    error.centre_error = (aligned_centre - t->cam_from_world.centre()).norm();
    // The estimate's camera-from-truth-world rotation is R_e R_a^T.
    Eigen::Quaterniond aligned_rotation = e->cam_from_world.rotation * result.alignment.rotation.conjugate();
    error.rotation_error_deg = rotation_angle_deg(aligned_rotation * t->cam_from_world.rotation.conjugate());
    compare_intrinsics(*e, *t, error);
    centre.push_back(error.centre_error);
    rotation.push_back(error.rotation_error_deg);
    if (error.focal_relative_error) focal.push_back(*error.focal_relative_error);
    if (error.principal_point_error_px) principal.push_back(*error.principal_point_error_px);
    result.cameras.push_back(std::move(error));
  }
  std::vector<double> orientation = orientation_aligned_rotation_errors_deg(estimate, truth);
  if (orientation.size() == result.cameras.size())
    for (std::size_t k = 0; k < orientation.size(); ++k)
      result.cameras[k].orientation_error_deg = orientation[k];
  result.centre_error = summarize(centre);
  result.rotation_error_deg = summarize(rotation);
  result.orientation_error_deg = summarize(orientation);
  result.focal_relative_error = summarize(focal);
  result.principal_point_error_px = summarize(principal);
  return result;
}

nlohmann::json CameraEvalResult::to_json() const {
  nlohmann::json cams = nlohmann::json::array();
  for (const CameraError& c : cameras) {
    nlohmann::json j = {{"id", c.id},
                        {"centre_error", c.centre_error},
                        {"rotation_error_deg", c.rotation_error_deg},
                        {"orientation_error_deg", c.orientation_error_deg}};
    j["focal_relative_error"] = c.focal_relative_error ? json_number(*c.focal_relative_error) : nullptr;
    j["principal_point_error_px"] =
        c.principal_point_error_px ? json_number(*c.principal_point_error_px) : nullptr;
    cams.push_back(std::move(j));
  }
  const Eigen::Quaterniond& q = alignment.rotation;
  return {
      {"alignment",
       {{"kind", to_string(alignment_kind)},
        {"cameras", aligned_on},
        {"scale", alignment.scale},
        {"rotation_wxyz", {q.w(), q.x(), q.y(), q.z()}},
        {"translation", {alignment.translation.x(), alignment.translation.y(), alignment.translation.z()}}}},
      {"matched", cameras.size()},
      {"missing_in_estimate", missing_in_estimate},
      {"extra_in_estimate", extra_in_estimate},
      {"centre_error", centre_error.to_json()},
      {"rotation_error_deg", rotation_error_deg.to_json()},
      {"orientation_error_deg", orientation_error_deg.to_json()},
      {"focal_relative_error", focal_relative_error.to_json()},
      {"principal_point_error_px", principal_point_error_px.to_json()},
      {"cameras", std::move(cams)},
  };
}

std::string CameraEvalResult::to_text() const {
  std::string text = str(cameras.size(), " cameras matched");
  if (!missing_in_estimate.empty())
    text += str(", ", missing_in_estimate.size(), " missing from the estimate");
  if (!extra_in_estimate.empty()) text += str(", ", extra_in_estimate.size(), " not in the truth");
  if (alignment_kind == CameraAlignment::similarity)
    text += str("; similarity alignment on ", aligned_on, " cameras, scale ", alignment.scale);
  else
    text += "; no alignment";
  text += str(". Centre error mean ", centre_error.mean, ", median ", centre_error.median, ", max ",
              centre_error.max, ", RMS ", centre_error.rms, " (truth units). Rotation error mean ",
              rotation_error_deg.mean, " deg, median ", rotation_error_deg.median, " deg, max ",
              rotation_error_deg.max, " deg, RMS ", rotation_error_deg.rms,
              " deg. Orientation-aligned rotation error median ", orientation_error_deg.median, " deg, max ",
              orientation_error_deg.max, " deg.");
  if (focal_relative_error.count > 0)
    text += str(" Focal relative error mean ", focal_relative_error.mean, ", max ", focal_relative_error.max,
                "; principal point error mean ", principal_point_error_px.mean, " px over ",
                focal_relative_error.count, " cameras.");
  return text;
}

}  // namespace pg
