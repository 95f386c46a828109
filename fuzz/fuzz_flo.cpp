// Fuzz target: the Middlebury .flo optical flow reader.
#include "fuzz_input.h"
#include "pg/eval/flo_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".flo");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_flo(p); });
  return 0;
}
