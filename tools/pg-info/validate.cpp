#include "validate.h"

#include <algorithm>

#include "pg/camera/cameras_io.h"

#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"
#include "pg/eval/flo_io.h"
#include "pg/fusion/tsdf_volume.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/mesh/point_cloud.h"
#include "pg/mesh/vertex_mask.h"

namespace fs = std::filesystem;

namespace pg::info {
namespace {

std::string lower_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

std::string validate_json(const fs::path& path) {
  auto doc = read_json_file(path);
  if (!doc.is_object() || !doc.contains("format") || !doc["format"].is_string())
    throw InputError(path, "not a pg JSON file (no \"format\" field)");
  std::string format = doc["format"].get<std::string>();
  if (format == "pg-cameras") {
    auto set = read_cameras(path);
    return str("pg-cameras: ", set.cameras.size(), " cameras, ", set.rigs.size(), " rigs");
  }
  if (format == "pg-vertex-mask") {
    auto mask = read_vertex_mask(path);
    return str("pg-vertex-mask '", mask.name, "': ", mask.weights.size(), " vertices");
  }
  // Other JSON formats: the common header is checked.
  int version = check_format_header(doc, path, format, 1);
  return str(format, " v", version);
}

}  // namespace

std::string validate_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "no such file");
  std::string ext = lower_extension(path);
  if (ext == ".json") return validate_json(path);
  if (ext == ".ply" || ext == ".obj") {
    Mesh mesh = read_mesh(path);
    return str("mesh: ", mesh.vertex_count(), " vertices, ", mesh.face_count(), " faces");
  }
  if (ext == ".flo") {
    const cv::Mat2f flow = read_flo(path);
    return str("flo: ", flow.cols, "x", flow.rows);
  }
  if (ext == ".vdb") {
    const fusion::TsdfVolume volume = fusion::TsdfVolume::read_vdb(path);
    return str("pg-tsdf: voxel size ", volume.voxel_size(), ", ", volume.active_voxel_count(),
               " active voxels");
  }
  if (ext == ".exr" && is_pg_depth_exr(path)) {
    DepthMap depth = read_depth_exr(path);
    return str("pg-depth-exr: ", depth.depth.cols, "x", depth.depth.rows);
  }
  cv::Mat image = read_image(path);
  return str("image: ", image.cols, "x", image.rows, ", ", image.channels(), " channels");
}

}  // namespace pg::info
