// Fuzz target: the PLY mesh reader, ASCII and binary (formats/mesh-ply.md).
#include "fuzz_input.h"
#include "pg/mesh/ply_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".ply");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_mesh_ply(p); });
  return 0;
}
