#pragma once
// The few EXIF fields that fix a photo's focal length in pixels, read from a JPEG's APP1 segment
// (or a TIFF file's own header). Only what self-calibration needs; everything else is ignored.
#include <filesystem>
#include <optional>
#include <span>
#include <string>

namespace pg {

struct ExifFocal {
  std::optional<double> focal_mm;               // FocalLength
  std::optional<double> focal_35mm;             // FocalLengthIn35mmFilm
  std::optional<double> focal_plane_px_per_mm;  // FocalPlaneXResolution over its unit
  std::optional<int> pixel_width;               // PixelXDimension: the width the above refer to
  std::string make, model;
};

// The focal fields of a JPEG or TIFF; all empty when the file has no EXIF block. Malformed EXIF is
// treated as absent (a photo's metadata never stops a run), but an unreadable file is an InputError.
ExifFocal read_exif_focal(const std::filesystem::path& file);

// Parses the fields from the bytes of a whole JPEG or TIFF file.
ExifFocal parse_exif_focal(std::span<const unsigned char> file_bytes);

// The focal length in pixels for an image `width` x `height` pixels, from the sensor's pixel pitch
// when known, else from the 35 mm equivalent (defined on the 43.27 mm diagonal); empty when neither.
std::optional<double> focal_px_from_exif(const ExifFocal& exif, int width, int height);

}  // namespace pg
