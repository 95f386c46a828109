// Fuzz target: the tracks file reader (formats/tracks.md).
#include "fuzz_input.h"
#include "pg/track/tracks.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".json");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) { pg::read_tracks(p); });
  return 0;
}
