#include "pg/image/exif.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <vector>

#include "pg/core/error.h"

namespace pg {
namespace {

constexpr std::uint16_t kExifIfdPointer = 0x8769;
constexpr std::uint16_t kMake = 0x010F, kModel = 0x0110;
constexpr std::uint16_t kPixelXDimension = 0xA002;
constexpr std::uint16_t kFocalLength = 0x920A, kFocalLength35mm = 0xA405;
constexpr std::uint16_t kFocalPlaneXResolution = 0xA20E, kFocalPlaneResolutionUnit = 0xA210;

// Bounds-checked reads from a TIFF block in either byte order.
class Tiff {
 public:
  explicit Tiff(std::span<const unsigned char> bytes) : bytes_(bytes) {
    if (bytes.size() < 8) return;
    if (bytes[0] == 'I' && bytes[1] == 'I')
      little_ = true;
    else if (bytes[0] == 'M' && bytes[1] == 'M')
      little_ = false;
    else
      return;
    valid_ = u16(2) == 42;
  }
  bool valid() const { return valid_; }
  bool has(std::size_t offset, std::size_t size) const {
    return offset <= bytes_.size() && size <= bytes_.size() - offset;
  }
  std::uint16_t u16(std::size_t at) const {
    if (!has(at, 2)) return 0;
    return little_ ? std::uint16_t(bytes_[at] | bytes_[at + 1] << 8)
                   : std::uint16_t(bytes_[at] << 8 | bytes_[at + 1]);
  }
  std::uint32_t u32(std::size_t at) const {
    if (!has(at, 4)) return 0;
    const std::uint32_t a = u16(at), b = u16(at + 2);
    return little_ ? a | b << 16 : a << 16 | b;
  }
  std::span<const unsigned char> bytes() const { return bytes_; }

 private:
  std::span<const unsigned char> bytes_;
  bool little_ = true, valid_ = false;
};

constexpr std::uint16_t kAscii = 2, kShort = 3, kLong = 4, kRational = 5;

struct Entry {
  std::uint16_t tag = 0, type = 0;
  std::uint32_t count = 0;
  std::size_t value_at = 0;  // offset of the value (inline when it fits in 4 bytes)
};

std::size_t type_size(std::uint16_t type) {
  switch (type) {
    case kAscii:
      return 1;
    case kShort:
      return 2;
    case kLong:
      return 4;
    case kRational:
      return 8;
    default:
      return 0;
  }
}

std::vector<Entry> read_ifd(const Tiff& tiff, std::size_t at) {
  std::vector<Entry> entries;
  if (!tiff.has(at, 2)) return entries;
  const std::size_t n = tiff.u16(at);
  if (!tiff.has(at + 2, n * 12)) return entries;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t e = at + 2 + 12 * i;
    Entry entry{tiff.u16(e), tiff.u16(e + 2), tiff.u32(e + 4), e + 8};
    const std::size_t size = type_size(entry.type);
    if (size == 0 || entry.count == 0 || entry.count > 1 << 16) continue;
    if (size * entry.count > 4) entry.value_at = tiff.u32(e + 8);
    if (!tiff.has(entry.value_at, size * entry.count)) continue;
    entries.push_back(entry);
  }
  return entries;
}

std::optional<double> number(const Tiff& tiff, const Entry& e) {
  switch (e.type) {
    case kShort:
      return tiff.u16(e.value_at);
    case kLong:
      return tiff.u32(e.value_at);
    case kRational: {
      const double den = tiff.u32(e.value_at + 4);
      if (den == 0) return std::nullopt;
      return tiff.u32(e.value_at) / den;
    }
    default:
      return std::nullopt;
  }
}

std::string text(const Tiff& tiff, const Entry& e) {
  if (e.type != kAscii) return {};
  std::string s(reinterpret_cast<const char*>(tiff.bytes().data() + e.value_at), e.count);
  s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::optional<double> positive(std::optional<double> v) {
  return v && std::isfinite(*v) && *v > 0 ? v : std::nullopt;
}

ExifFocal parse_tiff(const Tiff& tiff) {
  ExifFocal exif;
  if (!tiff.valid()) return exif;
  std::optional<double> plane_resolution;
  double unit_mm = 25.4;  // FocalPlaneResolutionUnit defaults to inches
  std::size_t exif_ifd = 0;
  for (const Entry& e : read_ifd(tiff, tiff.u32(4))) {
    if (e.tag == kMake) exif.make = text(tiff, e);
    if (e.tag == kModel) exif.model = text(tiff, e);
    if (e.tag == kExifIfdPointer) exif_ifd = tiff.u32(e.value_at);
  }
  if (exif_ifd == 0) return exif;
  for (const Entry& e : read_ifd(tiff, exif_ifd)) {
    if (e.tag == kFocalLength) exif.focal_mm = positive(number(tiff, e));
    if (e.tag == kFocalLength35mm) exif.focal_35mm = positive(number(tiff, e));
    if (e.tag == kFocalPlaneXResolution) plane_resolution = positive(number(tiff, e));
    if (e.tag == kPixelXDimension)
      if (auto w = positive(number(tiff, e)); w && *w <= 1 << 20) exif.pixel_width = static_cast<int>(*w);
    if (e.tag == kFocalPlaneResolutionUnit) {
      const auto unit = number(tiff, e).value_or(2);
      unit_mm = unit == 3 ? 10.0 : unit == 4 ? 1.0 : unit == 5 ? 1e-3 : 25.4;
    }
  }
  if (plane_resolution) exif.focal_plane_px_per_mm = *plane_resolution / unit_mm;
  return exif;
}

}  // namespace

ExifFocal parse_exif_focal(std::span<const unsigned char> bytes) {
  if (bytes.size() >= 4 && ((bytes[0] == 'I' && bytes[1] == 'I') || (bytes[0] == 'M' && bytes[1] == 'M')))
    return parse_tiff(Tiff(bytes));
  if (bytes.size() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return {};
  // JPEG markers up to the start of scan; EXIF lives in an APP1 segment starting "Exif\0\0".
  std::size_t at = 2;
  while (at + 4 <= bytes.size() && bytes[at] == 0xFF) {
    const unsigned char marker = bytes[at + 1];
    if (marker == 0xDA || marker == 0xD9) break;
    const std::size_t length = std::size_t(bytes[at + 2]) << 8 | bytes[at + 3];
    if (length < 2 || at + 2 + length > bytes.size()) break;
    const auto segment = bytes.subspan(at + 4, length - 2);
    if (marker == 0xE1 && segment.size() > 6 && std::equal(segment.begin(), segment.begin() + 6, "Exif\0\0"))
      return parse_tiff(Tiff(segment.subspan(6)));
    at += 2 + length;
  }
  return {};
}

ExifFocal read_exif_focal(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file, "cannot be opened");
  // EXIF sits in the first 64 KiB of a JPEG (APP1 is at most that long) and usually of a TIFF.
  std::vector<unsigned char> head(1 << 17);
  in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return parse_exif_focal(head);
}

std::optional<double> focal_px_from_exif(const ExifFocal& exif, int width, int height) {
  if (exif.focal_mm && exif.focal_plane_px_per_mm) {
    // The pixel pitch refers to the camera's own image width; scale to this image's width.
    const double resize = exif.pixel_width ? double(width) / *exif.pixel_width : 1.0;
    return *exif.focal_mm * *exif.focal_plane_px_per_mm * resize;
  }
  if (exif.focal_35mm) {
    const double diagonal_px = std::hypot(double(width), double(height));
    return *exif.focal_35mm * diagonal_px / std::hypot(36.0, 24.0);
  }
  return std::nullopt;
}

}  // namespace pg
