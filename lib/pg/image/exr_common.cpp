#include "pg/image/exr_common.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfTileDescription.h>
#include <OpenEXR/ImfXdr.h>
#include <OpenEXR/openexr.h>

#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/image_io.h"

namespace fs = std::filesystem;

namespace pg::exr {
namespace {

// OpenEXR's core library reports errors through a callback (by default it prints to stderr); keep the
// message for the InputError instead.
thread_local std::string g_core_message;
void keep_core_message(exr_const_context_t, exr_result_t, const char* message) {
  g_core_message = message ? message : "";
}

struct CoreContext {
  exr_context_t context = nullptr;
  ~CoreContext() {
    if (context) exr_finish(&context);
  }
};

// Address of pixel (0, 0) of the data window for OpenEXR's frame buffer, whose slices are addressed in
// absolute data-window coordinates.
char* frame_buffer_base(const cv::Mat& image, int component, const Imath::Box2i& window) {
  const std::ptrdiff_t x_stride = static_cast<std::ptrdiff_t>(image.elemSize());
  const std::ptrdiff_t y_stride = static_cast<std::ptrdiff_t>(image.step[0]);
  return reinterpret_cast<char*>(image.data) + component * sizeof(float) -
         (static_cast<std::ptrdiff_t>(window.min.x) * x_stride +
          static_cast<std::ptrdiff_t>(window.min.y) * y_stride);
}

Imf::FrameBuffer frame_buffer(const std::vector<Slice>& slices, const Imath::Box2i& window) {
  Imf::FrameBuffer buffer;
  for (const Slice& s : slices)
    buffer.insert(s.name,
                  Imf::Slice(Imf::FLOAT, frame_buffer_base(s.image, s.component, window), s.image.elemSize(),
                             s.image.step[0], 1, 1, std::numeric_limits<float>::quiet_NaN()));
  return buffer;
}

// OpenEXR 3.1's C++ header reader consumes known attribute types by their structure, not by the size
// the header states: fixed-size types read their fixed size, a channel list reads up to its empty
// name, a preview reads width x height pixels. Other types (strings, vectors, unknown ones) read the
// stated size. These are the fixed sizes.
std::optional<std::int64_t> fixed_attribute_size(const std::string& type) {
  static const std::map<std::string, std::int64_t> sizes = {{"box2i", 16},      {"box2f", 16},
                                                            {"compression", 1}, {"lineOrder", 1},
                                                            {"envmap", 1},      {"deepImageState", 1},
                                                            {"int", 4},         {"float", 4},
                                                            {"double", 8},      {"v2i", 8},
                                                            {"v2f", 8},         {"v2d", 16},
                                                            {"v3i", 12},        {"v3f", 12},
                                                            {"v3d", 24},        {"m33f", 36},
                                                            {"m33d", 72},       {"m44f", 64},
                                                            {"m44d", 128},      {"chromaticities", 32},
                                                            {"keycode", 28},    {"rational", 8},
                                                            {"timecode", 8},    {"tiledesc", 9}};
  const auto it = sizes.find(type);
  return it == sizes.end() ? std::nullopt : std::optional(it->second);
}

// Walks the header's attributes the way OpenEXR's C++ reader will and rejects one that would make it
// allocate more bytes than the file holds (a string or an unknown attribute is allocated at its
// stated size before it is read: a corrupt size would allocate, and clear, gigabytes).
void check_attribute_sizes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(0, std::ios::end);
  const std::int64_t file_size = in.tellg();
  in.seekg(0);
  const auto read_int = [&](std::int32_t& value) {
    unsigned char b[4];
    if (!in.read(reinterpret_cast<char*>(b), 4)) return false;
    value = std::int32_t(std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 |
                         std::uint32_t(b[3]) << 24);
    return true;
  };
  // A name or type: at most 255 characters and a terminating zero; "" ends a header.
  const auto read_name = [&](std::string& name) {
    name.clear();
    for (char c; in.get(c);) {
      if (c == '\0') return true;
      if (name.size() == 255) return false;
      name.push_back(c);
    }
    return false;
  };
  const auto require_bytes = [&](const std::string& name, std::int64_t bytes) {
    const std::int64_t remaining = file_size - std::int64_t(in.tellg());
    if (bytes < 0 || bytes > remaining) {
      std::string printable = name;  // a corrupt name must not garble the one-line error
      for (char& c : printable)
        if (c < 0x20 || c > 0x7e) c = '?';
      throw InputError(path, str("OpenEXR header attribute '", printable, "' needs ", bytes, " bytes but ",
                                 remaining, " remain in the file"));
    }
  };
  std::int32_t magic = 0, version = 0;
  if (!read_int(magic) || !read_int(version)) return;  // the core preflight names the problem
  const bool multipart = (version & 0x1000) != 0;
  for (int header = 0;; ++header) {
    std::string name, type, channel;
    int attributes = 0;
    while (read_name(name) && !name.empty()) {
      std::int32_t size = 0;
      if (!read_name(type) || !read_int(size)) return;
      if (type == "chlist") {
        while (read_name(channel) && !channel.empty()) in.seekg(16, std::ios::cur);
      } else if (type == "preview") {
        std::int32_t width = 0, height = 0;
        if (!read_int(width) || !read_int(height)) return;
        // RGBA bytes of width x height, saturated: (2^32)^2 x 4 does not fit in 64 bits.
        const std::uint64_t pixels = std::uint64_t(std::uint32_t(width)) * std::uint32_t(height);
        const std::int64_t bytes =
            pixels > std::uint64_t(INT64_MAX / 4) ? INT64_MAX : std::int64_t(4 * pixels);
        require_bytes(name, bytes);
        in.seekg(bytes, std::ios::cur);
      } else if (const auto fixed = fixed_attribute_size(type)) {
        in.seekg(*fixed, std::ios::cur);
      } else {
        require_bytes(name, size);
        in.seekg(size, std::ios::cur);
      }
      if (!in) return;
      ++attributes;
    }
    // A single-part file has one header; a multi-part file ends its list with an empty header.
    if (!multipart || attributes == 0 || !in || header > 10000) return;
  }
}

// Scanlines OpenEXR decodes together for a compression (its line buffers hold this many lines).
int lines_per_chunk(Imf::Compression compression) {
  switch (compression) {
    case Imf::ZIP_COMPRESSION:
    case Imf::PXR24_COMPRESSION:
      return 16;
    case Imf::PIZ_COMPRESSION:
    case Imf::B44_COMPRESSION:
    case Imf::B44A_COMPRESSION:
    case Imf::DWAA_COMPRESSION:
      return 32;
    case Imf::DWAB_COMPRESSION:
      return 256;
    default:
      return 1;
  }
}

// The header as Imf::InputFile will read it, checked before InputFile sizes its buffers from it. The
// core library that preflight uses can read a corrupt header differently (a box2i attribute whose
// declared size is wrong: the core keeps a default window, Imf reads the 16 bytes), so a file that
// passes the core check could still make InputFile allocate gigabytes for one chunk of lines.
void check_imf_buffers(const fs::path& path) {
  Imf::Header header;
  try {
    Imf::StdIFStream in(path.c_str());
    int magic = 0, version = 0;
    Imf::Xdr::read<Imf::StreamIO>(in, magic);
    Imf::Xdr::read<Imf::StreamIO>(in, version);
    header.readFrom(in, version);
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot read the OpenEXR header: ") + e.what());
  }
  const Imath::Box2i window = header.dataWindow();
  const std::int64_t width = std::int64_t{window.max.x} - window.min.x + 1;
  const std::int64_t height = std::int64_t{window.max.y} - window.min.y + 1;
  check_image_size(path, width, height);
  std::int64_t bytes_per_pixel = 0;
  for (auto c = header.channels().begin(); c != header.channels().end(); ++c)
    bytes_per_pixel += c.channel().type == Imf::HALF ? 2 : 4;
  std::int64_t chunk_pixels = width * lines_per_chunk(header.compression());
  if (header.hasTileDescription()) {
    const Imf::TileDescription& tile = header.tileDescription();
    chunk_pixels = std::int64_t{tile.xSize} * tile.ySize;
  }
  const std::int64_t chunk_bytes = chunk_pixels * bytes_per_pixel;
  if (chunk_bytes > max_exr_chunk_bytes)
    throw InputError(path, str("OpenEXR chunk of ", chunk_bytes, " bytes (", chunk_pixels, " pixels of ",
                               bytes_per_pixel, " bytes) exceeds the limit of ", max_exr_chunk_bytes));
}

}  // namespace

cv::Size preflight(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "file does not exist or is not a regular file");
  check_attribute_sizes(path);
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = &keep_core_message;
  CoreContext core;
  g_core_message.clear();
  if (exr_start_read(&core.context, path.c_str(), &init) != EXR_ERR_SUCCESS)
    throw InputError(path, "not a readable OpenEXR file (" + g_core_message + ")");
  exr_storage_t storage = EXR_STORAGE_LAST_TYPE;
  if (exr_get_storage(core.context, 0, &storage) != EXR_ERR_SUCCESS)
    throw InputError(path, "OpenEXR file without a readable first part");
  if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
    throw InputError(path, "deep OpenEXR images are not supported");
  exr_attr_box2i_t window{};
  if (exr_get_data_window(core.context, 0, &window) != EXR_ERR_SUCCESS)
    throw InputError(path, "OpenEXR header without a data window");
  const std::int64_t width = std::int64_t{window.max.x} - window.min.x + 1;
  const std::int64_t height = std::int64_t{window.max.y} - window.min.y + 1;
  check_image_size(path, width, height);
  check_imf_buffers(path);
  return {static_cast<int>(width), static_cast<int>(height)};
}

std::unique_ptr<Imf::InputFile> open(const fs::path& path) {
  preflight(path);
  try {
    return std::make_unique<Imf::InputFile>(path.c_str());
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot open OpenEXR file: ") + e.what());
  }
}

void check_float_channel(const fs::path& path, const Imf::Header& header, const std::string& name) {
  const Imf::Channel* channel = header.channels().findChannel(name);
  if (!channel) throw InputError(path, "missing channel '" + name + "'");
  if (channel->type != Imf::HALF && channel->type != Imf::FLOAT)
    throw InputError(path, "channel '" + name + "' has pixel type UINT; expected HALF or FLOAT");
  if (channel->xSampling != 1 || channel->ySampling != 1)
    throw InputError(path, "channel '" + name + "' is subsampled; only full-resolution channels are read");
}

void read_slices(const fs::path& path, Imf::InputFile& file, const std::vector<Slice>& slices) {
  const Imath::Box2i window = file.header().dataWindow();
  try {
    if (!file.isComplete()) throw InputError(path, "incomplete OpenEXR file (pixel data missing)");
    file.setFrameBuffer(frame_buffer(slices, window));
    file.readPixels(window.min.y, window.max.y);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot read OpenEXR pixels: ") + e.what());
  }
}

void write_slices(const fs::path& target, Imf::Header header, const std::vector<Slice>& slices) {
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const Slice& s : slices) header.channels().insert(s.name, Imf::Channel(Imf::FLOAT));
  try {
    Imf::OutputFile out(target.c_str(), header);
    out.setFrameBuffer(frame_buffer(slices, header.dataWindow()));
    const Imath::Box2i window = header.dataWindow();
    out.writePixels(window.max.y - window.min.y + 1);
  } catch (const std::exception& e) {
    throw OutputError(target, std::string("cannot write OpenEXR file: ") + e.what());
  }
}

Imf::Header header_for_size(cv::Size size) {
  return Imf::Header(size.width, size.height);
}

}  // namespace pg::exr
