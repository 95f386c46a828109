#pragma once
// One camera as JSON (formats/cameras.md): the object stored in a cameras file's "cameras" array and in
// depth-map EXR headers.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "pg/camera/camera.h"

namespace pg {

// Keys in reading order: id, image, width, height, model, intrinsics, distortion, cam_from_world, then
// quality, rig and stddev when set. Equirectangular cameras have no intrinsics or distortion; fisheye
// distortion holds k1..k4 only. Doubles are written so that they read back bit for bit.
nlohmann::ordered_json camera_to_ordered_json(const Camera& camera);
nlohmann::json camera_to_json(const Camera& camera);

// Validates and reads one camera. Throws InputError naming `file`, `where` (e.g. "cameras[3]") and the
// camera id: unknown model, unknown or missing fields, width/height outside [1, 65536], focal lengths
// not positive, non-finite numbers, a rotation quaternion whose norm is more than 1e-3 from 1 (it is
// normalised when it differs from 1 by more than 1e-12), quality outside [0, 1], negative stddev.
Camera camera_from_json(const nlohmann::json& j, const std::filesystem::path& file, const std::string& where);

}  // namespace pg
