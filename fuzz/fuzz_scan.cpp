// Fuzz target: the range-scan readers of pg-merge: the header probe that tells meshes from bare
// points (inspect_scan), scans as triangles (PLY meshes and Stanford range grids, read_scan_mesh) and
// as points with sensor origins, normals, confidence and colour (read_scan_points).
#include "fuzz_input.h"
#include "pg/fusion/scan.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".ply");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::fusion::inspect_scan(p); });
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::fusion::read_scan_mesh(p); });
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::fusion::read_scan_points(p); });
  return 0;
}
