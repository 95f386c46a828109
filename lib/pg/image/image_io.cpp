#include "pg/image/image_io.h"

#include <OpenEXR/ImfChannelList.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string_view>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/exr_common.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

constexpr std::array<unsigned char, 8> png_signature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr std::array<unsigned char, 4> exr_magic = {0x76, 0x2f, 0x31, 0x01};

std::string lower_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

void require_regular_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "file does not exist or is not a regular file");
}

std::ifstream open_binary(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open for reading");
  return in;
}

bool starts_with(std::ifstream& in, const unsigned char* magic, std::size_t n) {
  std::array<unsigned char, 8> buffer{};
  in.seekg(0);
  in.read(reinterpret_cast<char*>(buffer.data()), static_cast<std::streamsize>(n));
  const bool match =
      in.gcount() == static_cast<std::streamsize>(n) && std::memcmp(buffer.data(), magic, n) == 0;
  in.clear();
  in.seekg(0);
  return match;
}

std::uint32_t big_endian(std::ifstream& in, int bytes) {
  std::uint32_t value = 0;
  for (int i = 0; i < bytes; ++i) {
    const int c = in.get();
    if (c == EOF) return 0;
    value = (value << 8) | static_cast<std::uint32_t>(c);
  }
  return value;
}

std::optional<cv::Size> png_size(const fs::path& path, std::ifstream& in) {
  in.seekg(12);
  char chunk[4];
  in.read(chunk, 4);
  if (!in || std::memcmp(chunk, "IHDR", 4) != 0) throw InputError(path, "corrupt PNG header (no IHDR chunk)");
  const std::uint32_t width = big_endian(in, 4), height = big_endian(in, 4);
  if (!in) throw InputError(path, "truncated PNG header");
  check_image_size(path, width, height);
  return cv::Size(static_cast<int>(width), static_cast<int>(height));
}

// Walks the JPEG marker segments up to the first start-of-frame, which holds the size.
std::optional<cv::Size> jpeg_size(const fs::path& path, std::ifstream& in) {
  in.seekg(2);
  while (in) {
    int c = in.get();
    if (c != 0xff) break;
    int marker = in.get();
    while (marker == 0xff) marker = in.get();
    if (marker == EOF) break;
    if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd9)) continue;  // no payload
    const std::uint32_t length = big_endian(in, 2);
    if (length < 2) break;
    const bool start_of_frame =
        marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (start_of_frame) {
      in.get();  // sample precision
      const std::uint32_t height = big_endian(in, 2), width = big_endian(in, 2);
      if (!in) break;
      if (height == 0) return std::nullopt;  // height given later by a DNL marker: let the decoder check
      check_image_size(path, width, height);
      return cv::Size(static_cast<int>(width), static_cast<int>(height));
    }
    in.seekg(length - 2, std::ios::cur);
  }
  throw InputError(path, "corrupt JPEG header (no frame header found)");
}

// Radiance RGBE: text lines up to an empty line, then "-Y <height> +X <width>" (or another orientation).
std::optional<cv::Size> radiance_size(const fs::path& path, std::ifstream& in) {
  std::string line;
  for (int lines = 0; std::getline(in, line) && lines < 1000; ++lines) {
    if (!line.empty()) continue;
    if (!std::getline(in, line)) break;
    std::istringstream resolution(line);
    std::string axis1, axis2;
    long long n1 = 0, n2 = 0;
    if (!(resolution >> axis1 >> n1 >> axis2 >> n2) || axis1.size() != 2 || axis2.size() != 2) break;
    const bool y_first = axis1[1] == 'Y';
    const long long width = y_first ? n2 : n1, height = y_first ? n1 : n2;
    check_image_size(path, width, height);
    return cv::Size(static_cast<int>(width), static_cast<int>(height));
  }
  throw InputError(path, "corrupt Radiance HDR header (no resolution line)");
}

double unit_scale(int depth) {
  switch (depth) {
    case CV_8U:
      return 1.0 / 255.0;
    case CV_16U:
      return 1.0 / 65535.0;
    case CV_32F:
    case CV_64F:
      return 1.0;
    default:
      throw UsageError("image conversion: unsupported sample type (expected 8-bit, 16-bit or float)");
  }
}

cv::Mat to_float(const cv::Mat& image) {
  cv::Mat out;
  image.convertTo(out, CV_32F, unit_scale(image.depth()));
  zero_non_finite(out);
  return out;
}

// EXR: B G R [A] from R G B [A], else Y, else the only channel (e.g. a bare Z). Float data.
cv::Mat read_exr_image(const fs::path& path) {
  std::unique_ptr<Imf::InputFile> file = exr::open(path);
  const Imf::ChannelList& channels = file->header().channels();
  std::vector<std::string> names;
  if (channels.findChannel("R") && channels.findChannel("G") && channels.findChannel("B")) {
    names = {"B", "G", "R"};
    if (channels.findChannel("A")) names.push_back("A");
  } else if (channels.findChannel("Y")) {
    names = {"Y"};
  } else if (channels.begin() != channels.end() && ++channels.begin() == channels.end()) {
    names = {channels.begin().name()};
  } else {
    throw InputError(path, "OpenEXR image without R G B or Y channels (and more than one other channel)");
  }
  std::vector<exr::Slice> slices;
  const Imath::Box2i window = file->header().dataWindow();
  cv::Mat image(window.max.y - window.min.y + 1, window.max.x - window.min.x + 1,
                CV_32FC(static_cast<int>(names.size())));
  for (std::size_t i = 0; i < names.size(); ++i) {
    exr::check_float_channel(path, file->header(), names[i]);
    slices.push_back({names[i], image, static_cast<int>(i)});
  }
  exr::read_slices(path, *file, slices);
  return image;
}

// The formats pg hands to OpenCV, by their leading bytes. OpenCV would also try JPEG 2000, DICOM
// (GDCM) and others whose decoders are not hardened against hostile files (GDCM aborts on some), so
// anything else is refused before decoding.
bool opencv_format_supported(const fs::path& path) {
  std::ifstream in = open_binary(path);
  std::array<unsigned char, 12> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  const std::size_t n = static_cast<std::size_t>(in.gcount());
  const auto is = [&](std::size_t offset, std::string_view magic) {
    return n >= offset + magic.size() && std::memcmp(head.data() + offset, magic.data(), magic.size()) == 0;
  };
  const bool png = is(0, std::string_view(reinterpret_cast<const char*>(png_signature.data()), 8));
  const bool jpeg = is(0, "\xff\xd8\xff");
  const bool tiff = is(0, std::string_view("II*\0", 4)) || is(0, std::string_view("MM\0*", 4)) ||
                    is(0, std::string_view("II+\0", 4)) || is(0, std::string_view("MM\0+", 4));
  const bool radiance = is(0, "#?");
  const bool bmp = is(0, "BM");
  const bool webp = is(0, "RIFF") && is(8, "WEBP");
  const bool netpbm =
      n >= 2 && head[0] == 'P' && ((head[1] >= '1' && head[1] <= '7') || head[1] == 'F' || head[1] == 'f');
  return png || jpeg || tiff || radiance || bmp || webp || netpbm;
}

cv::Mat read_with_opencv(const fs::path& path) {
  if (!opencv_format_supported(path))
    throw InputError(path,
                     "not an image format pg reads (PNG, JPEG, TIFF, OpenEXR, Radiance HDR, BMP, WebP, "
                     "PNM/PAM/PFM)");
  peek_image_size(path);  // throws for oversized or corrupt headers before decoding
  cv::Mat image;
  try {
    image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(path, "cannot decode image: " + e.msg);
  }
  if (image.empty()) throw InputError(path, "cannot decode image (unsupported format or corrupt file)");
  check_image_size(path, image.cols, image.rows);
  if (image.depth() == CV_64F) image.convertTo(image, CV_32F);
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F)
    throw InputError(path, "unsupported sample type (expected 8-bit, 16-bit or float)");
  if (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)
    throw InputError(path, str("unsupported channel count ", image.channels()));
  return image;
}

bool is_exr(const fs::path& path) {
  std::ifstream in = open_binary(path);
  return starts_with(in, exr_magic.data(), exr_magic.size());
}

void require_type(const fs::path& path, const cv::Mat& image, std::initializer_list<int> depths,
                  std::initializer_list<int> channels, const char* what) {
  const bool depth_ok = std::find(depths.begin(), depths.end(), image.depth()) != depths.end();
  const bool channels_ok = std::find(channels.begin(), channels.end(), image.channels()) != channels.end();
  if (!depth_ok || !channels_ok)
    throw OutputError(path, str("cannot store a ", image.channels(), "-channel image of depth ",
                                image.depth(), " as ", what));
}

void write_exr_image(const fs::path& target, const fs::path& tmp, const cv::Mat& image) {
  require_type(target, image, {CV_32F}, {1, 3, 4}, "EXR (float, 1, 3 or 4 channels)");
  static const std::vector<std::string> grey = {"Y"}, bgr = {"B", "G", "R"}, bgra = {"B", "G", "R", "A"};
  const std::vector<std::string>& names = image.channels() == 1 ? grey : image.channels() == 3 ? bgr : bgra;
  std::vector<exr::Slice> slices;
  for (std::size_t i = 0; i < names.size(); ++i) slices.push_back({names[i], image, static_cast<int>(i)});
  exr::write_slices(tmp, exr::header_for_size(image.size()), slices);
}

}  // namespace

void check_image_size(const fs::path& file, std::int64_t width, std::int64_t height) {
  if (width <= 0 || height <= 0) throw InputError(file, str("empty image (", width, " x ", height, ")"));
  if (width > max_image_side || height > max_image_side || width * height > max_image_pixels)
    throw InputError(file, str("image of ", width, " x ", height, " pixels exceeds the limit of ",
                               max_image_pixels, " pixels and ", max_image_side, " per side"));
}

std::optional<cv::Size> peek_image_size(const fs::path& path) {
  require_regular_file(path);
  std::ifstream in = open_binary(path);
  static constexpr unsigned char jpeg_magic[] = {0xff, 0xd8, 0xff};
  static constexpr unsigned char radiance_magic[] = {'#', '?'};
  if (starts_with(in, png_signature.data(), png_signature.size())) return png_size(path, in);
  if (starts_with(in, jpeg_magic, sizeof jpeg_magic)) return jpeg_size(path, in);
  if (starts_with(in, radiance_magic, sizeof radiance_magic)) return radiance_size(path, in);
  if (starts_with(in, exr_magic.data(), exr_magic.size())) return exr::preflight(path);
  return std::nullopt;
}

cv::Mat read_image(const fs::path& path, ReadMode mode) {
  require_regular_file(path);
  cv::Mat image = is_exr(path) ? read_exr_image(path) : read_with_opencv(path);
  switch (mode) {
    case ReadMode::unchanged:
      return image;
    case ReadMode::gray_float:
      return to_float_gray(image);
    case ReadMode::color_float:
      return to_float_color(image);
  }
  return image;
}

void write_image(const fs::path& path, const cv::Mat& image) {
  if (image.empty()) throw OutputError(path, "empty image");
  const std::string ext = lower_extension(path);
  if (ext == ".png")
    require_type(path, image, {CV_8U, CV_16U}, {1, 3, 4}, "PNG (8 or 16-bit)");
  else if (ext == ".jpg" || ext == ".jpeg")
    require_type(path, image, {CV_8U}, {1, 3}, "JPEG (8-bit, 1 or 3 channels)");
  else if (ext == ".hdr")
    require_type(path, image, {CV_32F}, {1, 3}, "Radiance HDR (float)");
  else if (ext == ".tif" || ext == ".tiff")
    require_type(path, image, {CV_8U, CV_16U, CV_32F}, {1, 3, 4}, "TIFF");
  else if (ext != ".exr")
    throw OutputError(path, "unsupported image extension '" + ext + "' (png, jpg, exr, hdr, tif)");
  write_atomically(path, [&](const fs::path& tmp) {
    if (ext == ".exr") return write_exr_image(path, tmp, image);
    bool written = false;
    try {
      written = cv::imwrite(tmp.string(), image);
    } catch (const cv::Exception& e) {
      throw OutputError(path, "cannot encode image: " + e.msg);
    }
    if (!written) throw OutputError(path, "cannot encode or write image");
  });
}

std::size_t zero_non_finite(cv::Mat& image) {
  if (image.depth() != CV_32F) return 0;
  std::size_t count = 0;
  for (int y = 0; y < image.rows; ++y) {
    float* row = image.ptr<float>(y);
    for (int i = 0, n = image.cols * image.channels(); i < n; ++i)
      if (!std::isfinite(row[i])) {
        row[i] = 0.0f;
        ++count;
      }
  }
  return count;
}

cv::Mat to_float_gray(const cv::Mat& image) {
  cv::Mat values = to_float(image);
  switch (values.channels()) {
    case 1:
      return values;
    case 3:
      cv::cvtColor(values, values, cv::COLOR_BGR2GRAY);
      return values;
    case 4:
      cv::cvtColor(values, values, cv::COLOR_BGRA2GRAY);
      return values;
    default:
      throw UsageError(str("to_float_gray: unsupported channel count ", image.channels()));
  }
}

cv::Mat to_float_color(const cv::Mat& image) {
  cv::Mat values = to_float(image);
  switch (values.channels()) {
    case 1:
      cv::cvtColor(values, values, cv::COLOR_GRAY2BGR);
      return values;
    case 3:
      return values;
    case 4:
      cv::cvtColor(values, values, cv::COLOR_BGRA2BGR);
      return values;
    default:
      throw UsageError(str("to_float_color: unsupported channel count ", image.channels()));
  }
}

std::uint64_t decoded_image_bytes_per_pixel(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  if (extension == ".jpg" || extension == ".jpeg") return 3;
  if (extension == ".png") return 8;
  return 16;
}

}  // namespace pg
