// Fuzz target: the vertex mask reader (formats/vertex-mask.md).
#include "fuzz_input.h"
#include "pg/mesh/vertex_mask.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".pgmask.json");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_vertex_mask(p); });
  return 0;
}
