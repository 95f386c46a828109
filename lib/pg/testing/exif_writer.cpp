#include "pg/testing/exif_writer.h"

#include <cstdint>
#include <stdexcept>

namespace pg::testing {
namespace {

struct Tag {
  std::uint16_t id, type;
  std::uint32_t count;
  std::vector<unsigned char> value;  // already in file byte order
};

class Writer {
 public:
  explicit Writer(bool big_endian) : big_(big_endian) {}
  std::vector<unsigned char> u16(std::uint32_t v) const {
    return big_ ? std::vector<unsigned char>{uint8(v >> 8), uint8(v)}
                : std::vector<unsigned char>{uint8(v), uint8(v >> 8)};
  }
  std::vector<unsigned char> u32(std::uint32_t v) const {
    auto hi = u16(v >> 16), lo = u16(v & 0xFFFF);
    if (!big_) std::swap(hi, lo);
    hi.insert(hi.end(), lo.begin(), lo.end());
    return hi;
  }
  std::vector<unsigned char> rational(double v) const {
    auto out = u32(static_cast<std::uint32_t>(v * 1000 + 0.5));
    const auto den = u32(1000);
    out.insert(out.end(), den.begin(), den.end());
    return out;
  }
  // An IFD at `at` (offset in the TIFF block) with values that do not fit inline placed after it.
  std::vector<unsigned char> ifd(std::uint32_t at, const std::vector<Tag>& tags) const {
    std::vector<unsigned char> head, extra;
    append(head, u16(static_cast<std::uint32_t>(tags.size())));
    const std::uint32_t extra_at = at + 2 + 12 * static_cast<std::uint32_t>(tags.size()) + 4;
    for (const Tag& t : tags) {
      append(head, u16(t.id));
      append(head, u16(t.type));
      append(head, u32(t.count));
      if (t.value.size() <= 4) {
        std::vector<unsigned char> inline_value = t.value;
        inline_value.resize(4, 0);
        append(head, inline_value);
      } else {
        append(head, u32(extra_at + static_cast<std::uint32_t>(extra.size())));
        append(extra, t.value);
      }
    }
    append(head, u32(0));  // no next IFD
    append(head, extra);
    return head;
  }
  static void append(std::vector<unsigned char>& to, const std::vector<unsigned char>& v) {
    to.insert(to.end(), v.begin(), v.end());
  }

 private:
  static unsigned char uint8(std::uint32_t v) { return static_cast<unsigned char>(v & 0xFF); }
  bool big_;
};

}  // namespace

std::vector<unsigned char> with_exif(const std::vector<unsigned char>& jpeg, const ExifFields& f,
                                     bool big_endian) {
  if (jpeg.size() < 2 || jpeg[0] != 0xFF || jpeg[1] != 0xD8) throw std::invalid_argument("not a JPEG");
  const Writer w(big_endian);
  std::vector<Tag> exif_tags;
  if (f.pixel_width) exif_tags.push_back({0xA002, 4, 1, w.u32(*f.pixel_width)});
  if (f.focal_mm) exif_tags.push_back({0x920A, 5, 1, w.rational(*f.focal_mm)});
  if (f.plane_px_per_unit) exif_tags.push_back({0xA20E, 5, 1, w.rational(*f.plane_px_per_unit)});
  if (f.plane_unit) exif_tags.push_back({0xA210, 3, 1, w.u16(*f.plane_unit)});
  if (f.focal_35mm) exif_tags.push_back({0xA405, 3, 1, w.u16(static_cast<std::uint32_t>(*f.focal_35mm))});

  std::vector<Tag> ifd0_tags;
  if (!f.make.empty()) {
    std::vector<unsigned char> text(f.make.begin(), f.make.end());
    text.push_back(0);
    ifd0_tags.push_back({0x010F, 2, static_cast<std::uint32_t>(text.size()), text});
  }
  // IFD0 at offset 8; its size depends only on its tags, so the EXIF IFD's offset is known first.
  ifd0_tags.push_back({0x8769, 4, 1, w.u32(0)});
  const std::uint32_t exif_at = static_cast<std::uint32_t>(8 + w.ifd(8, ifd0_tags).size());
  ifd0_tags.back().value = w.u32(exif_at);

  std::vector<unsigned char> tiff =
      big_endian ? std::vector<unsigned char>{'M', 'M'} : std::vector<unsigned char>{'I', 'I'};
  Writer::append(tiff, w.u16(42));
  Writer::append(tiff, w.u32(8));
  Writer::append(tiff, w.ifd(8, ifd0_tags));
  Writer::append(tiff, w.ifd(exif_at, exif_tags));

  std::vector<unsigned char> segment = {'E', 'x', 'i', 'f', 0, 0};
  Writer::append(segment, tiff);
  const std::size_t length = segment.size() + 2;
  std::vector<unsigned char> out = {0xFF,
                                    0xD8,
                                    0xFF,
                                    0xE1,
                                    static_cast<unsigned char>(length >> 8),
                                    static_cast<unsigned char>(length & 0xFF)};
  Writer::append(out, segment);
  out.insert(out.end(), jpeg.begin() + 2, jpeg.end());
  return out;
}

}  // namespace pg::testing
