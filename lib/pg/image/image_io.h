#pragma once
// Reading and writing ordinary images (formats/images.md). 8-bit, 16-bit and float data are kept as
// they are unless a ReadMode asks for a conversion. EXR goes through OpenEXR directly (OpenCV 4.6
// disables its EXR codec by default); PNG, JPEG, TIFF, Radiance .hdr and the rest go through OpenCV.
// Sizes are checked from the file header before any pixel is decoded where the format allows.
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>

namespace pg {

// Largest image any pg reader decodes: 2^28 pixels (16k x 16k), and no side above 65536.
inline constexpr std::int64_t max_image_pixels = std::int64_t{1} << 28;
inline constexpr std::int64_t max_image_side = 65536;

// Throws InputError(file, ...) when width x height is empty or exceeds the bounds above.
void check_image_size(const std::filesystem::path& file, std::int64_t width, std::int64_t height);

enum class ReadMode {
  unchanged,    // as stored: CV_8U, CV_16U or CV_32F; 1, 3 (BGR) or 4 (BGRA) channels
  gray_float,   // CV_32FC1; 8/16-bit scaled to [0, 1], float data untouched
  color_float,  // CV_32FC3 (BGR); same scaling; grey replicated, alpha dropped
};

// Missing, unreadable, unsupported or oversized files throw InputError(path, problem).
cv::Mat read_image(const std::filesystem::path& path, ReadMode mode = ReadMode::unchanged);

// Width and height from the file header without decoding pixels, for PNG, JPEG, EXR and Radiance
// .hdr. nullopt for other formats. Throws InputError if the file is missing or its header is corrupt.
std::optional<cv::Size> peek_image_size(const std::filesystem::path& path);

// Bound on the bytes per pixel of an image decoded by read_image (ReadMode::unchanged), from its file
// type, for estimates made before decoding: JPEG 3 (8-bit, at most 3 channels), PNG 8 (up to 16-bit
// RGBA), anything else 16 (float RGBA: EXR, HDR, TIFF).
std::uint64_t decoded_image_bytes_per_pixel(const std::filesystem::path& path);

// Writes atomically; the codec follows the extension: .png (8/16-bit), .jpg/.jpeg (8-bit),
// .exr (float; ZIP compressed, channels Y, or B G R [A]), .hdr (float, 3 channels), .tif/.tiff.
// A depth the codec cannot store throws OutputError (no silent rescaling).
void write_image(const std::filesystem::path& path, const cv::Mat& image);

// Conversions used by ReadMode, for images already in memory. NaN and infinite samples become 0.
cv::Mat to_float_gray(const cv::Mat& image);
cv::Mat to_float_color(const cv::Mat& image);

// Sets the NaN and infinite samples of a float image (any channel count) to 0, black: one such pixel
// of a scene-linear plate (a comp's division by zero) would otherwise spread through a flow's
// smoothing, a window sum or a mean. Other depths are left alone. Returns how many samples it set.
std::size_t zero_non_finite(cv::Mat& image);

}  // namespace pg
