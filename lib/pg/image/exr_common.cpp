#include "pg/image/exr_common.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/openexr.h>

#include <limits>

#include "pg/core/error.h"
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

}  // namespace

cv::Size preflight(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "file does not exist or is not a regular file");
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
