#pragma once
// The cameras file (formats/cameras.md): format "pg-cameras", version 1.
#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/core/provenance.h"

namespace pg {

inline constexpr const char* cameras_format_name = "pg-cameras";
inline constexpr int cameras_format_version = 1;

// Cameras that move together (a stereo pair, two panoramas shot from one head).
struct Rig {
  std::string id;
  std::vector<std::string> camera_ids;
  // Only for a rig of exactly two cameras: the nominal centre of camera_ids[1] in the frame of
  // camera_ids[0], in scene units (e.g. {0, -0.27, 0}: a second panorama 27 cm above the first).
  std::optional<Eigen::Vector3d> offset;
};

struct CameraSet {
  std::vector<Camera> cameras;
  std::vector<Rig> rigs;
  Provenance provenance;
  // The camera with this id, or nullptr.
  const Camera* find(const std::string& id) const;
};

// Reads and validates a cameras file. Throws InputError naming the file (and the camera or rig at
// fault): wrong format or version, unknown or missing fields, invalid cameras (see camera_from_json),
// duplicate camera or rig ids, a rig naming an unknown camera or listing a camera twice, a camera in
// two rigs, a camera whose "rig" disagrees with the rig listing it, an offset on a rig that does not
// have exactly two cameras.
CameraSet read_cameras(const std::filesystem::path& path);
// The same checks on an already parsed document; `path` names it in errors.
CameraSet cameras_from_json(const nlohmann::json& doc, const std::filesystem::path& path);

// Writes atomically, with Provenance::current() when set.provenance was never filled (empty
// created_utc). Throws OutputError when the set would not read back (the same checks as the reader).
void write_cameras(const std::filesystem::path& path, const CameraSet& set);
nlohmann::ordered_json cameras_to_json(const CameraSet& set);

}  // namespace pg
