#include "digest.h"

#include <algorithm>

#include "pg/camera/camera_json.h"
#include "pg/core/hash.h"
#include "pg/core/json_file.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"

namespace fs = std::filesystem;

namespace pg::info {
namespace {

void hash_mat(Sha256& h, const cv::Mat& m) {
  if (m.empty()) return;
  cv::Mat c = m.isContinuous() ? m : m.clone();
  int header[3] = {c.rows, c.cols, c.type()};
  h.update(header, sizeof header);
  h.update(c.data, c.total() * c.elemSize());
}

template <class T>
void hash_vector(Sha256& h, const std::vector<T>& v) {
  std::uint64_t n = v.size();
  h.update(&n, sizeof n);
  if (!v.empty()) h.update(v.data(), v.size() * sizeof(T));
}

void hash_string(Sha256& h, const std::string& s) { h.update(s.data(), s.size()); }

bool is_pg_depth(const fs::path& path) {
  try {
    read_depth_exr(path);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace

std::string content_digest(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  Sha256 h;
  if (ext == ".json") {
    nlohmann::json doc = read_json_file(path);
    if (doc.is_object()) doc.erase("provenance");
    hash_string(h, doc.dump());
  } else if (ext == ".ply" || ext == ".obj") {
    Mesh mesh = read_mesh(path);
    hash_vector(h, mesh.positions);
    hash_vector(h, mesh.faces);
    hash_vector(h, mesh.normals);
    hash_vector(h, mesh.colors);
    hash_vector(h, mesh.uvs);
    for (const auto& [name, values] : mesh.vertex_properties) {
      hash_string(h, name);
      hash_vector(h, values);
    }
  } else if (ext == ".exr" && is_pg_depth(path)) {
    DepthMap d = read_depth_exr(path);
    hash_mat(h, d.depth);
    hash_mat(h, d.confidence);
    hash_mat(h, d.normals);
    hash_mat(h, d.mask);
    hash_string(h, to_string(d.kind));
    hash_string(h, camera_to_json(d.camera).dump());
  } else {
    hash_mat(h, read_image(path));
  }
  return h.hex_digest();
}

}  // namespace pg::info
