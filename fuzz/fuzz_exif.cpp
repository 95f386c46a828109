// Fuzz target: the EXIF focal-length reader (JPEG APP1 / TIFF headers of the photos pg-track reads).
#include <cstdint>
#include <span>

#include "pg/image/exif.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const pg::ExifFocal exif = pg::parse_exif_focal(std::span(data, size));
  pg::focal_px_from_exif(exif, 4000, 3000);
  return 0;
}
