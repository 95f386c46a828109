// Fuzz target: the depth EXR readers (formats/depth-exr.md), pg's own files and foreign ones.
#include "fuzz_input.h"
#include "pg/image/depth_exr.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".exr");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_depth_exr_header(p); });
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_depth_exr(p); });
  // A foreign depth image must match the given camera's size; the seed depth-8x6.exr does.
  pg::Camera camera;
  camera.width = 8;
  camera.height = 6;
  camera.intrinsics.fx = camera.intrinsics.fy = 8.0;
  camera.intrinsics.cx = 3.5;
  camera.intrinsics.cy = 2.5;
  pg::fuzz::read_accepting_input_errors(
      path, [&](const auto& p) { pg::read_depth_exr_foreign(p, camera, pg::DepthKind::perspective_z); });
  return 0;
}
