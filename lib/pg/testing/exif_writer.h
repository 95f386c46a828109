#pragma once
// Writes a minimal EXIF block into a JPEG, for tests of the EXIF reader and of self-calibration.
#include <optional>
#include <string>
#include <vector>

namespace pg::testing {

struct ExifFields {
  std::optional<double> focal_mm, focal_35mm, plane_px_per_unit;
  std::optional<int> plane_unit, pixel_width;  // unit: 2 inch, 3 cm, 4 mm
  std::string make;
};

// `jpeg` with an APP1 EXIF segment holding `fields` inserted after its SOI marker.
std::vector<unsigned char> with_exif(const std::vector<unsigned char>& jpeg, const ExifFields& fields,
                                     bool big_endian = false);

}  // namespace pg::testing
