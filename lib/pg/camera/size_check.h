#pragma once
// The size checks every stage makes before decoding a file that belongs to a camera: an image, a
// mask or a depth image must have the camera's size, and one camera's images one size.
#include <filesystem>
#include <string>

#include "pg/camera/camera.h"

namespace pg {

// Throws InputError(file, "<what> is WxH but camera '<id>' is WxH") unless width x height is the
// camera's size. `what` names the file's role: "image", "mask", ...
void require_camera_size(const std::filesystem::path& file, int width, int height, const Camera& camera,
                         const std::string& what = "image");

struct FrameSize {
  std::string id;
  int width = 0, height = 0;
};

// Throws InputError(file, "frame <id> is WxH but frame <first id> is WxH; one camera cannot take
// images of different sizes") unless `frame`, the image in `file`, has the size of `first`.
void require_same_size(const std::filesystem::path& file, const FrameSize& frame, const FrameSize& first);

}  // namespace pg
