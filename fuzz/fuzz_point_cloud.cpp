// Fuzz target: the PLY point cloud reader (sparse and dense points).
#include "fuzz_input.h"
#include "pg/mesh/point_cloud.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".ply");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_point_cloud_ply(p); });
  return 0;
}
