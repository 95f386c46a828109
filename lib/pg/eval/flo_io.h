#pragma once
// Middlebury .flo optical flow files: the float 202021.25 ("PIEH"), int32 width, int32 height, then
// width*height (u, v) float32 pairs, row-major, little-endian. Unknown flow is marked by values above
// 1e9 in the file; in memory it is NaN (formats/conventions.md: invalid is NaN).
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>

namespace pg {

inline constexpr int max_flo_dimension = 1 << 16;
inline constexpr float flo_unknown_threshold = 1e9f;  // |u| or |v| above this: unknown
inline constexpr float flo_unknown_value = 1e10f;     // what write_flo stores for NaN

// Throws InputError on a missing file, bad magic, a size outside [1, 65536] or a file whose length
// disagrees with its header (checked before allocating). Unknown (> 1e9) and NaN vectors become NaN.
cv::Mat2f read_flo(const std::filesystem::path& path);

// Writes atomically; NaN components are stored as 1e10 (Middlebury's unknown marker).
void write_flo(const std::filesystem::path& path, const cv::Mat2f& flow);

// True when the vector is a known flow (finite and not Middlebury's unknown marker).
inline bool flow_is_known(const cv::Vec2f& f) {
  return std::abs(f[0]) <= flo_unknown_threshold && std::abs(f[1]) <= flo_unknown_threshold;
}

}  // namespace pg
