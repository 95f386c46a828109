#include "pg/camera/camera_json.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "pg/core/error.h"
#include "pg/core/json_file.h"

namespace pg {
namespace {

constexpr int max_image_side = 65536;

// The distortion keys each model stores, in file order, with the matching Distortion member.
struct DistortionKey {
  const char* name;
  double Distortion::*member;
};
constexpr DistortionKey pinhole_keys[] = {
    {"k1", &Distortion::k1}, {"k2", &Distortion::k2}, {"k3", &Distortion::k3}, {"k4", &Distortion::k4},
    {"k5", &Distortion::k5}, {"k6", &Distortion::k6}, {"p1", &Distortion::p1}, {"p2", &Distortion::p2}};
constexpr DistortionKey fisheye_keys[] = {
    {"k1", &Distortion::k1}, {"k2", &Distortion::k2}, {"k3", &Distortion::k3}, {"k4", &Distortion::k4}};

std::vector<DistortionKey> distortion_keys(CameraModel model) {
  if (model == CameraModel::pinhole) return {std::begin(pinhole_keys), std::end(pinhole_keys)};
  if (model == CameraModel::fisheye) return {std::begin(fisheye_keys), std::end(fisheye_keys)};
  return {};
}

void reject_unknown_keys(const JsonReader& reader, const std::vector<std::string>& allowed) {
  for (const auto& [key, value] : reader.node().items())
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
      reader.fail("unknown field \"" + key + "\"");
}

template <class Json>
Json to_json_impl(const Camera& camera) {
  Json j;
  j["id"] = camera.id;
  j["image"] = camera.image;
  j["width"] = camera.width;
  j["height"] = camera.height;
  j["model"] = to_string(camera.model);
  if (camera.model != CameraModel::equirectangular) {
    j["intrinsics"] = {{"fx", camera.intrinsics.fx},
                       {"fy", camera.intrinsics.fy},
                       {"cx", camera.intrinsics.cx},
                       {"cy", camera.intrinsics.cy}};
    Json distortion = Json::object();
    for (const DistortionKey& key : distortion_keys(camera.model))
      distortion[key.name] = camera.distortion.*key.member;
    j["distortion"] = distortion;
  }
  const Eigen::Quaterniond& q = camera.cam_from_world.rotation;
  const Eigen::Vector3d& t = camera.cam_from_world.translation;
  j["cam_from_world"] = {{"rotation_xyzw", {q.x(), q.y(), q.z(), q.w()}},
                         {"translation", {t.x(), t.y(), t.z()}}};
  if (camera.quality) j["quality"] = *camera.quality;
  if (camera.rig) j["rig"] = *camera.rig;
  if (camera.stddev) j["stddev"] = *camera.stddev;
  return j;
}

}  // namespace

nlohmann::ordered_json camera_to_ordered_json(const Camera& camera) {
  return to_json_impl<nlohmann::ordered_json>(camera);
}

nlohmann::json camera_to_json(const Camera& camera) {
  return to_json_impl<nlohmann::json>(camera);
}

Camera camera_from_json(const nlohmann::json& j, const std::filesystem::path& file,
                        const std::string& where) {
  const JsonReader unnamed(j, file, where);
  Camera camera;
  camera.id = unnamed.string("id");
  if (camera.id.empty()) unnamed.fail("\"id\" is empty");
  const JsonReader reader(j, file, (where.empty() ? "" : where + " ") + "camera \"" + camera.id + "\"");

  try {
    camera.model = camera_model_from_string(reader.string("model"));
  } catch (const UsageError& e) {
    reader.fail(e.what());
  }

  std::vector<std::string> allowed = {"id",      "image", "width", "height", "model", "cam_from_world",
                                      "quality", "rig",   "stddev"};
  if (camera.is_perspective()) {
    allowed.push_back("intrinsics");
    allowed.push_back("distortion");
  }
  reject_unknown_keys(reader, allowed);

  camera.image = reader.string("image");
  const long long width = reader.integer("width"), height = reader.integer("height");
  if (width < 1 || width > max_image_side || height < 1 || height > max_image_side)
    reader.fail("image size " + std::to_string(width) + "x" + std::to_string(height) + " is outside 1.." +
                std::to_string(max_image_side));
  camera.width = int(width);
  camera.height = int(height);

  if (camera.is_perspective()) {
    const JsonReader intrinsics = reader.child("intrinsics");
    reject_unknown_keys(intrinsics, {"fx", "fy", "cx", "cy"});
    camera.intrinsics = {intrinsics.number("fx"), intrinsics.number("fy"), intrinsics.number("cx"),
                         intrinsics.number("cy")};
    if (!(camera.intrinsics.fx > 0 && camera.intrinsics.fy > 0))
      intrinsics.fail("focal lengths must be positive");
    const JsonReader distortion = reader.child("distortion");
    std::vector<std::string> names;
    for (const DistortionKey& key : distortion_keys(camera.model)) {
      names.push_back(key.name);
      camera.distortion.*key.member = distortion.number(key.name);
    }
    reject_unknown_keys(distortion, names);
  }

  const JsonReader pose = reader.child("cam_from_world");
  reject_unknown_keys(pose, {"rotation_xyzw", "translation"});
  const std::vector<double> q = pose.numbers("rotation_xyzw", 4);
  const std::vector<double> t = pose.numbers("translation", 3);
  Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
  const double norm = rotation.norm();
  if (!(std::abs(norm - 1) <= 1e-3))
    pose.fail("\"rotation_xyzw\" has norm " + std::to_string(norm) + ", expected a unit quaternion");
  // Renormalising a quaternion that is unit to rounding would change its last bits on every round trip.
  if (std::abs(norm - 1) > 1e-12) rotation.normalize();
  camera.cam_from_world = {rotation, {t[0], t[1], t[2]}};

  if (j.contains("quality")) {
    const double quality = reader.number("quality");
    if (!(quality >= 0 && quality <= 1)) reader.fail("\"quality\" must be within [0, 1]");
    camera.quality = quality;
  }
  if (j.contains("rig")) {
    camera.rig = reader.string("rig");
    if (camera.rig->empty()) reader.fail("\"rig\" is empty");
  }
  if (j.contains("stddev")) {
    const std::vector<double> values = reader.numbers("stddev", 12);
    std::array<double, 12> stddev;
    for (std::size_t i = 0; i < stddev.size(); ++i) {
      if (values[i] < 0) reader.fail("\"stddev\" holds a negative value");
      stddev[i] = values[i];
    }
    camera.stddev = stddev;
  }
  return camera;
}

}  // namespace pg
