#include "digest.h"

#include <openvdb/openvdb.h>

#include <algorithm>

#include "pg/camera/camera_json.h"
#include "pg/core/error.h"
#include "pg/core/hash.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"
#include "pg/eval/flo_io.h"
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

void hash_string(Sha256& h, const std::string& s) {
  h.update(s.data(), s.size());
}

bool is_pg_depth(const fs::path& path) {
  try {
    read_depth_exr(path);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

template <class Grid>
bool hash_active_values(Sha256& h, const openvdb::GridBase::Ptr& base) {
  const auto grid = openvdb::gridPtrCast<Grid>(base);
  if (!grid) return false;
  for (auto it = grid->cbeginValueOn(); it; ++it) {
    const openvdb::Coord c = it.getCoord();
    const typename Grid::ValueType v = *it;
    h.update(c.data(), sizeof(openvdb::Int32) * 3);
    h.update(&v, sizeof v);
  }
  return true;
}

// Every grid's name, voxel size and active voxels (coordinates and values, in tree order), and the
// file metadata except pg/provenance.
void hash_vdb(Sha256& h, const fs::path& path) {
  openvdb::initialize();
  try {
    openvdb::io::File file(path.string());
    file.open(false);
    const auto meta = file.getMetadata();
    for (auto it = meta->beginMeta(); it != meta->endMeta(); ++it) {
      if (it->first == "pg/provenance") continue;
      hash_string(h, it->first);
      hash_string(h, it->second->str());
    }
    std::vector<std::string> names;
    for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(it.gridName());
    std::sort(names.begin(), names.end());
    for (const std::string& name : names) {
      const openvdb::GridBase::Ptr grid = file.readGrid(name);
      hash_string(h, name);
      hash_string(h, grid->valueType());
      const openvdb::Vec3d voxel = grid->voxelSize();
      h.update(voxel.asPointer(), sizeof(double) * 3);
      if (!hash_active_values<openvdb::FloatGrid>(h, grid) &&
          !hash_active_values<openvdb::Vec3SGrid>(h, grid))
        throw InputError(
            path, str("grid \"", name, "\" has a value type digest does not know: ", grid->valueType()));
    }
  } catch (const openvdb::Exception& e) {
    throw InputError(path, str("not a readable OpenVDB file: ", e.what()));
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
  } else if (ext == ".vdb") {
    hash_vdb(h, path);
  } else if (ext == ".flo") {
    hash_mat(h, read_flo(path));
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
