// Fuzz target: the text lists pg-merge reads beside its inputs: Stanford .conf scan placements
// (read_stanford_conf) and RGB-D pose lists (cameras_from_pose_list).
#include "fuzz_input.h"
#include "pg/fusion/depth_frame.h"
#include "pg/fusion/scan.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".txt");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::fusion::read_stanford_conf(p); });
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) {
    pg::Intrinsics intrinsics;
    intrinsics.fx = intrinsics.fy = 525;
    intrinsics.cx = 319.5;
    intrinsics.cy = 239.5;
    pg::fusion::cameras_from_pose_list(p, intrinsics, 640, 480);
  });
  return 0;
}
