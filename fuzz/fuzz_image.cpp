// Fuzz target: the image reader (EXR by pg's own code, PNG/JPEG/TIFF/HDR through OpenCV), in every
// read mode, and the size peek used before reading.
#include <optional>

#include "fuzz_input.h"
#include "pg/image/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // The first byte picks the read mode; the reader dispatches on content, not on the extension.
  const auto mode = static_cast<pg::ReadMode>(data[0] % 3);
  const auto path = pg::fuzz::write_scratch(data + 1, size - 1, ".img");
  std::optional<cv::Size> peeked;
  pg::fuzz::read_accepting_input_errors(path, [&](const auto& p) { peeked = pg::peek_image_size(p); });
  // A legal header may describe up to max_image_pixels (2^28): decoding one is a memory test, not a
  // parser test, and exceeds the fuzzer's RSS limit, so large images are only peeked.
  if (peeked && std::int64_t(peeked->width) * peeked->height > (std::int64_t{1} << 22)) return 0;
  pg::fuzz::read_accepting_input_errors(path, [&](const auto& p) { pg::read_image(p, mode); });
  return 0;
}
