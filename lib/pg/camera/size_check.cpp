#include "pg/camera/size_check.h"

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg {

void require_camera_size(const std::filesystem::path& file, int width, int height, const Camera& camera,
                         const std::string& what) {
  if (width != camera.width || height != camera.height)
    throw InputError(file, str(what, " is ", width, "x", height, " but camera '", camera.id, "' is ",
                               camera.width, "x", camera.height));
}

void require_same_size(const std::filesystem::path& file, const FrameSize& frame, const FrameSize& first) {
  if (frame.width != first.width || frame.height != first.height)
    throw InputError(
        file, str("frame ", frame.id, " is ", frame.width, "x", frame.height, " but frame ", first.id, " is ",
                  first.width, "x", first.height, "; one camera cannot take images of different sizes"));
}

}  // namespace pg
