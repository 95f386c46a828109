#pragma once
// Depth maps as OpenEXR files, format "pg-depth-exr" version 1 (formats/depth-exr.md).
// Channels (FLOAT, ZIP): Z, and optionally confidence, N.x N.y N.z, mask. Header strings pg/format,
// pg/version, pg/depthKind, pg/camera (JSON), pg/provenance (JSON); standard worldToCamera and, for
// undistorted pinhole cameras, worldToNDC matrices so compositing tools see the camera.
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "pg/camera/camera.h"
#include "pg/core/provenance.h"

namespace pg {

inline constexpr const char* depth_exr_format = "pg-depth-exr";
inline constexpr int depth_exr_version = 1;

// perspective_z: distance along the optical axis (camera z). spherical_range: distance from the
// camera centre along the pixel's ray. Equirectangular cameras only carry spherical_range.
enum class DepthKind { perspective_z, spherical_range };
std::string to_string(DepthKind kind);
DepthKind depth_kind_from_string(const std::string& name);  // throws UsageError

struct DepthMap {
  cv::Mat depth;       // CV_32FC1, NaN = invalid
  cv::Mat confidence;  // empty or CV_32FC1 in [0, 1]
  cv::Mat normals;     // empty or CV_32FC3: (x, y, z) in the camera frame, unit length or NaN
  cv::Mat mask;        // empty or CV_8UC1, 255 = excluded by the user, 0 = kept
  DepthKind kind = DepthKind::perspective_z;
  Camera camera;  // width x height must equal depth's size
  Provenance provenance;
};

// Reads and validates a pg depth EXR. Throws InputError(path, problem) for anything that does not
// follow the format: not an EXR, wrong or missing pg/format, unsupported pg/version, missing Z,
// channels that are not HALF or FLOAT (HALF is converted), incomplete normals, an oversized data
// window (checked before allocating), bad camera JSON, a camera whose size differs from the data
// window, an unknown depth kind or perspective_z with an equirectangular camera.
DepthMap read_depth_exr(const std::filesystem::path& path);

// What a pg depth EXR's header says, read with every check read_depth_exr makes before it reads pixels
// (format, version, kind, camera, data window, channel types), without reading any: for checking a
// stage's inputs up front. Throws InputError(path, problem) as read_depth_exr does.
struct DepthExrHeader {
  DepthKind kind = DepthKind::perspective_z;
  Camera camera;
  Provenance provenance;
};
DepthExrHeader read_depth_exr_header(const std::filesystem::path& path);

// True when `path` is an OpenEXR file whose header names a pg format (a depth map); false for any other
// file, a damaged one included (its reader says what is wrong). Reads the header only, with the same
// checks before allocating as read_depth_exr.
bool is_pg_depth_exr(const std::filesystem::path& path);

// Writes atomically. Throws OutputError for an inconsistent DepthMap (types, sizes, kind vs camera).
void write_depth_exr(const std::filesystem::path& path, const DepthMap& map);

// Interchange: a plain EXR from another tool with a Z (preferred) or Y channel and no pg header.
// Values that are not finite or not positive become NaN (tools write 0 or inf for "no depth").
// The camera's size must equal the data window. Provenance names the file as its input.
DepthMap read_depth_exr_foreign(const std::filesystem::path& path, const Camera& camera, DepthKind kind);

// A colour-mapped 8-bit PNG for looking at a depth map: near is warm (red), far is cool (blue), the
// range set by the 2nd and 98th percentiles of valid depths; invalid pixels black, masked pixels at
// half brightness. Written atomically.
void write_depth_preview_png(const std::filesystem::path& path, const DepthMap& map);

}  // namespace pg
