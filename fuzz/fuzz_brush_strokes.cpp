// Fuzz target: the brush strokes reader (formats/brush-strokes.md).
#include "fuzz_input.h"
#include "pg/refine/brush_strokes.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".json");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_brush_strokes(p); });
  return 0;
}
