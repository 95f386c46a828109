#include "pg/image/depth_exr.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "pg/camera/camera_json.h"
#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/exr_common.h"
#include "pg/image/image_io.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

constexpr const char* attr_format = "pg/format";
constexpr const char* attr_version = "pg/version";
constexpr const char* attr_kind = "pg/depthKind";
constexpr const char* attr_camera = "pg/camera";
constexpr const char* attr_provenance = "pg/provenance";
const std::vector<std::string> normal_channels = {"N.x", "N.y", "N.z"};

bool kind_fits_camera(DepthKind kind, const Camera& camera) {
  return kind == DepthKind::spherical_range || camera.is_perspective();
}

Imath::M44f imath_from_column_major(const Eigen::Matrix4d& m) {
  // Imath multiplies row vectors (p * M): its matrix is the transpose of the column-vector one.
  Imath::M44f out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[c][r] = static_cast<float>(m(r, c)) + 0.0f;  // + 0: no "-0" in dumps
  return out;
}

Eigen::Matrix4d homogeneous(const Rigid3& pose) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 4>() = pose.matrix();
  return m;
}

// OpenEXR's camera space is left-handed: x right, y up, z forward; ours has y down.
Eigen::Matrix4d exr_world_to_camera(const Camera& camera) {
  return Eigen::Vector4d(1, -1, 1, 1).asDiagonal() * homogeneous(camera.cam_from_world);
}

// World -> NDC (0, 0) top-left corner, (1, 1) bottom-right corner of the image, after the homogeneous
// divide. Pixel centre (0, 0) is half a pixel in from the corner.
Eigen::Matrix4d exr_world_to_ndc(const Camera& camera) {
  const Intrinsics& k = camera.intrinsics;
  const double w = camera.width, h = camera.height;
  Eigen::Matrix4d projection;
  projection << k.fx / w, 0, (k.cx + 0.5) / w, 0,  //
      0, k.fy / h, (k.cy + 0.5) / h, 0,            //
      0, 0, 0, 1,                                  //
      0, 0, 1, 0;
  return projection * homogeneous(camera.cam_from_world);
}

void check_for_write(const fs::path& path, const DepthMap& map) {
  if (map.depth.empty() || map.depth.type() != CV_32FC1)
    throw OutputError(path, "depth must be a non-empty CV_32FC1 image");
  const cv::Size size = map.depth.size();
  if (size.width > max_image_side || size.height > max_image_side ||
      std::int64_t{size.width} * size.height > max_image_pixels)
    throw OutputError(path, "depth map larger than readers accept");
  if (map.camera.width != size.width || map.camera.height != size.height)
    throw OutputError(path, str("camera is ", map.camera.width, " x ", map.camera.height, " but depth is ",
                                size.width, " x ", size.height));
  auto check_optional = [&](const cv::Mat& m, int type, const char* what) {
    if (!m.empty() && (m.type() != type || m.size() != size))
      throw OutputError(path, str(what, " must be empty or of depth's size and type ", type));
  };
  check_optional(map.confidence, CV_32FC1, "confidence");
  check_optional(map.normals, CV_32FC3, "normals");
  check_optional(map.mask, CV_8UC1, "mask");
  if (!kind_fits_camera(map.kind, map.camera))
    throw OutputError(
        path, "perspective_z depth needs a perspective camera (equirectangular carries spherical_range)");
}

const std::string* string_attribute(const Imf::Header& header, const char* name) {
  const auto* attribute = header.findTypedAttribute<Imf::StringAttribute>(name);
  return attribute ? &attribute->value() : nullptr;
}

const std::string& required_string(const fs::path& path, const Imf::Header& header, const char* name) {
  const std::string* value = string_attribute(header, name);
  if (!value) throw InputError(path, str("missing string header attribute ", name));
  return *value;
}

nlohmann::json parse_json_attribute(const fs::path& path, const Imf::Header& header, const char* name) {
  nlohmann::json j = nlohmann::json::parse(required_string(path, header, name), nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw InputError(path, str(name, " is not a JSON object"));
  return j;
}

void check_format_attributes(const fs::path& path, const Imf::Header& header) {
  const std::string* format = string_attribute(header, attr_format);
  if (!format)
    throw InputError(path, str("not a pg depth EXR: no ", attr_format,
                               " header attribute (plain EXRs are read with read_depth_exr_foreign)"));
  if (*format != depth_exr_format)
    throw InputError(path, str(attr_format, " is '", *format, "', expected '", depth_exr_format, "'"));
  const std::string& version = required_string(path, header, attr_version);
  const bool digits =
      !version.empty() && version.size() < 10 &&
      std::all_of(version.begin(), version.end(), [](char c) { return c >= '0' && c <= '9'; });
  const int number = digits ? std::stoi(version) : 0;
  if (number < 1 || number > depth_exr_version)
    throw InputError(path, str("unsupported ", attr_version, " '", version, "' (this reader supports 1 to ",
                               depth_exr_version, ")"));
}

// Sets values that are not finite or not positive to NaN, for depth from other tools.
void invalidate_non_positive(cv::Mat& depth) {
  depth.forEach<float>([](float& d, const int*) {
    if (!std::isfinite(d) || d <= 0) d = std::numeric_limits<float>::quiet_NaN();
  });
}

}  // namespace

std::string to_string(DepthKind kind) {
  return kind == DepthKind::perspective_z ? "perspective_z" : "spherical_range";
}

DepthKind depth_kind_from_string(const std::string& name) {
  if (name == "perspective_z") return DepthKind::perspective_z;
  if (name == "spherical_range") return DepthKind::spherical_range;
  throw UsageError("unknown depth kind '" + name + "' (perspective_z or spherical_range)");
}

void write_depth_exr(const fs::path& path, const DepthMap& map) {
  check_for_write(path, map);
  Imf::Header header = exr::header_for_size(map.depth.size());
  header.insert(attr_format, Imf::StringAttribute(depth_exr_format));
  header.insert(attr_version, Imf::StringAttribute(std::to_string(depth_exr_version)));
  header.insert(attr_kind, Imf::StringAttribute(to_string(map.kind)));
  header.insert(attr_camera, Imf::StringAttribute(camera_to_ordered_json(map.camera).dump()));
  header.insert(attr_provenance, Imf::StringAttribute(to_json(map.provenance).dump()));
  Imf::addWorldToCamera(header, imath_from_column_major(exr_world_to_camera(map.camera)));
  if (map.camera.model == CameraModel::pinhole && map.camera.distortion.is_zero())
    Imf::addWorldToNDC(header, imath_from_column_major(exr_world_to_ndc(map.camera)));

  std::vector<exr::Slice> slices = {{"Z", map.depth, 0}};
  if (!map.confidence.empty()) slices.push_back({"confidence", map.confidence, 0});
  if (!map.normals.empty())
    for (int i = 0; i < 3; ++i) slices.push_back({normal_channels[i], map.normals, i});
  if (!map.mask.empty()) {
    cv::Mat mask_float;
    cv::Mat excluded = map.mask > 0;
    excluded.convertTo(mask_float, CV_32F, 1.0 / 255.0);
    slices.push_back({"mask", mask_float, 0});
  }
  write_atomically(path, [&](const fs::path& tmp) { exr::write_slices(tmp, header, slices); });
}

namespace {

// The attributes read_depth_exr checks before it reads any pixel.
DepthExrHeader depth_exr_header(const fs::path& path, const Imf::Header& header) {
  check_format_attributes(path, header);
  DepthExrHeader out;
  const std::string& kind = required_string(path, header, attr_kind);
  try {
    out.kind = depth_kind_from_string(kind);
  } catch (const UsageError&) {
    throw InputError(path, str(attr_kind, " is '", kind, "', expected perspective_z or spherical_range"));
  }
  out.camera = camera_from_json(parse_json_attribute(path, header, attr_camera), path, attr_camera);
  out.provenance = provenance_from_json(parse_json_attribute(path, header, attr_provenance));
  const Imath::Box2i window = header.dataWindow();
  const cv::Size size(window.max.x - window.min.x + 1, window.max.y - window.min.y + 1);
  if (out.camera.width != size.width || out.camera.height != size.height)
    throw InputError(path, str("camera in ", attr_camera, " is ", out.camera.width, " x ", out.camera.height,
                               " but the data window is ", size.width, " x ", size.height));
  if (!kind_fits_camera(out.kind, out.camera))
    throw InputError(path, "perspective_z depth with an equirectangular camera");
  exr::check_float_channel(path, header, "Z");
  const Imf::ChannelList& channels = header.channels();
  for (const char* optional : {"confidence", "mask"})
    if (channels.findChannel(optional)) exr::check_float_channel(path, header, optional);
  const auto normals_present = std::count_if(normal_channels.begin(), normal_channels.end(),
                                             [&](const std::string& n) { return channels.findChannel(n); });
  if (normals_present != 0 && normals_present != 3)
    throw InputError(path, "incomplete normals: N.x, N.y and N.z must all be present or all absent");
  if (normals_present == 3)
    for (const std::string& n : normal_channels) exr::check_float_channel(path, header, n);
  return out;
}

}  // namespace

bool is_pg_depth_exr(const fs::path& path) {
  try {
    const std::unique_ptr<Imf::InputFile> file = exr::open(path);
    return file->header().find("pg/format") != file->header().end();
  } catch (const InputError&) {
    return false;
  }
}

DepthExrHeader read_depth_exr_header(const fs::path& path) {
  return depth_exr_header(path, exr::open(path)->header());
}

DepthMap read_depth_exr(const fs::path& path) {
  std::unique_ptr<Imf::InputFile> file = exr::open(path);
  const Imf::Header& header = file->header();
  DepthExrHeader parsed = depth_exr_header(path, header);
  DepthMap map;
  map.kind = parsed.kind;
  map.camera = std::move(parsed.camera);
  map.provenance = std::move(parsed.provenance);
  const cv::Size size(map.camera.width, map.camera.height);
  const Imf::ChannelList& channels = header.channels();
  map.depth.create(size, CV_32FC1);
  std::vector<exr::Slice> slices = {{"Z", map.depth, 0}};
  if (channels.findChannel("confidence")) {
    map.confidence.create(size, CV_32FC1);
    slices.push_back({"confidence", map.confidence, 0});
  }
  if (channels.findChannel(normal_channels[0])) {  // all three: depth_exr_header checked
    map.normals.create(size, CV_32FC3);
    for (int i = 0; i < 3; ++i) slices.push_back({normal_channels[i], map.normals, i});
  }
  cv::Mat mask_float;
  if (channels.findChannel("mask")) {
    mask_float.create(size, CV_32FC1);
    slices.push_back({"mask", mask_float, 0});
  }
  exr::read_slices(path, *file, slices);
  if (!mask_float.empty()) map.mask = mask_float > 0.5f;  // 255 where excluded; NaN reads as kept
  return map;
}

DepthMap read_depth_exr_foreign(const fs::path& path, const Camera& camera, DepthKind kind) {
  if (!kind_fits_camera(kind, camera))
    throw UsageError(
        "perspective_z depth needs a perspective camera (equirectangular carries spherical_range)");
  std::unique_ptr<Imf::InputFile> file = exr::open(path);
  const Imf::Header& header = file->header();
  const char* channel = header.channels().findChannel("Z")   ? "Z"
                        : header.channels().findChannel("Y") ? "Y"
                                                             : nullptr;
  if (!channel) throw InputError(path, "no Z or Y channel to read depth from");
  exr::check_float_channel(path, header, channel);
  const Imath::Box2i window = header.dataWindow();
  const cv::Size size(window.max.x - window.min.x + 1, window.max.y - window.min.y + 1);
  if (camera.width != size.width || camera.height != size.height)
    throw InputError(path, str("data window is ", size.width, " x ", size.height, " but the camera is ",
                               camera.width, " x ", camera.height));
  DepthMap map;
  map.depth.create(size, CV_32FC1);
  exr::read_slices(path, *file, {{channel, map.depth, 0}});
  invalidate_non_positive(map.depth);
  map.kind = kind;
  map.camera = camera;
  map.provenance.tool = "";
  map.provenance.inputs = {path.string()};
  return map;
}

void write_depth_preview_png(const fs::path& path, const DepthMap& map) {
  if (map.depth.empty() || map.depth.type() != CV_32FC1)
    throw OutputError(path, "depth must be a non-empty CV_32FC1 image");
  if (!map.mask.empty() && (map.mask.type() != CV_8UC1 || map.mask.size() != map.depth.size()))
    throw OutputError(path, "mask must be empty or a CV_8UC1 image of depth's size");
  std::vector<float> valid;
  valid.reserve(map.depth.total());
  for (int y = 0; y < map.depth.rows; ++y)
    for (int x = 0; x < map.depth.cols; ++x)
      if (const float d = map.depth.at<float>(y, x); std::isfinite(d)) valid.push_back(d);
  float near = 0, far = 1;
  if (!valid.empty()) {
    auto percentile = [&](double p) {
      auto it = valid.begin() + static_cast<std::ptrdiff_t>(std::lround(p * (valid.size() - 1)));
      std::nth_element(valid.begin(), it, valid.end());
      return *it;
    };
    near = percentile(0.02);
    far = percentile(0.98);
  }
  const float span = far > near ? far - near : 1.f;
  cv::Mat1b nearness(map.depth.size());
  for (int y = 0; y < map.depth.rows; ++y)
    for (int x = 0; x < map.depth.cols; ++x) {
      const float t = (far - map.depth.at<float>(y, x)) / span;  // 1 = near
      nearness(y, x) = cv::saturate_cast<uchar>(255.f * std::clamp(std::isfinite(t) ? t : 0.f, 0.f, 1.f));
    }
  cv::Mat colour;
  cv::applyColorMap(nearness, colour, cv::COLORMAP_TURBO);  // 255 = dark red, 0 = dark blue
  for (int y = 0; y < map.depth.rows; ++y)
    for (int x = 0; x < map.depth.cols; ++x) {
      cv::Vec3b& pixel = colour.at<cv::Vec3b>(y, x);
      if (!std::isfinite(map.depth.at<float>(y, x)))
        pixel = cv::Vec3b(0, 0, 0);
      else if (!map.mask.empty() && map.mask.at<uchar>(y, x))
        pixel /= 2;
    }
  write_image(path, colour);
}

}  // namespace pg
