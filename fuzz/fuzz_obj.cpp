// Fuzz target: the OBJ mesh reader.
#include "fuzz_input.h"
#include "pg/mesh/obj_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".obj");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_mesh_obj(p); });
  return 0;
}
