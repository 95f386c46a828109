#pragma once
// Shared OpenEXR plumbing for image_io and depth_exr (internal to the image module).
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace pg::exr {

// The most one chunk of an EXR (the scanlines decoded together, or one tile, over all channels) may
// take: OpenEXR allocates its line or tile buffers from the header before reading any pixel.
inline constexpr std::int64_t max_exr_chunk_bytes = std::int64_t{256} << 20;

// Reads only the header, with OpenEXR's core library and then as Imf::InputFile will (neither
// allocates per scanline), and rejects non-EXR files, deep images, data windows beyond
// max_image_pixels / max_image_side and chunks beyond max_exr_chunk_bytes. Returns the data window
// size. Throws InputError.
cv::Size preflight(const std::filesystem::path& path);

// Runs preflight() and opens the file; OpenEXR exceptions become InputError.
std::unique_ptr<Imf::InputFile> open(const std::filesystem::path& path);

// Throws InputError unless `name` is a full-resolution HALF or FLOAT channel of the header.
void check_float_channel(const std::filesystem::path& path, const Imf::Header& header,
                         const std::string& name);

// One EXR channel bound to component `component` of a CV_32FC(k) image of the data window's size.
// cv::Mat shares its buffer, so reading into a Slice fills the caller's image.
struct Slice {
  std::string name;
  cv::Mat image;
  int component = 0;
};

// Reads the slices (channels checked with check_float_channel); HALF data is converted by OpenEXR.
void read_slices(const std::filesystem::path& path, Imf::InputFile& file, const std::vector<Slice>& slices);

// Writes the slices as FLOAT channels with ZIP compression. `header` gives the windows and any extra
// attributes. No atomicity here: callers pass a temporary from write_atomically.
void write_slices(const std::filesystem::path& target, Imf::Header header, const std::vector<Slice>& slices);

// An OpenEXR header whose display and data windows are (0, 0) - (width - 1, height - 1).
Imf::Header header_for_size(cv::Size size);

}  // namespace pg::exr
