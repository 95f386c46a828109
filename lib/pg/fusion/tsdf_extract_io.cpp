// Mesh extraction, .vdb files and comparisons of TSDF volumes.
#include <openvdb/io/File.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/fusion/mesh_cleanup.h"
#include "pg/fusion/tsdf_grids.h"
#include "pg/mesh/manifold.h"

namespace pg::fusion {
namespace {

constexpr const char* vdb_format = "pg-tsdf";
constexpr int vdb_version = 1;

openvdb::FloatGrid::Ptr float_grid(openvdb::io::File& file, const std::string& name,
                                   const std::filesystem::path& path) {
  auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(name));
  if (!grid) throw InputError(path, str("grid \"", name, "\" is not a float grid"));
  return grid;
}

bool has_grid(openvdb::io::File& file, const std::string& name) {
  for (auto it = file.beginName(); it != file.endName(); ++it)
    if (*it == name) return true;
  return false;
}

// Whether every zero crossing on the edges of the cell with lower corner floor(p) lies between two
// observed voxels (and there is one). An unobserved voxel holds the background (+truncation), so a
// crossing towards it is not a measured surface; the cell's other corners may be unobserved.
bool crossings_observed(const openvdb::FloatGrid::ConstAccessor& surface,
                        const openvdb::FloatGrid::ConstAccessor& weights, const openvdb::Vec3d& p) {
  const openvdb::Coord base(int(std::floor(p.x())), int(std::floor(p.y())), int(std::floor(p.z())));
  auto corner = [&](int i) { return base.offsetBy(i & 1, (i >> 1) & 1, (i >> 2) & 1); };
  bool any = false;
  for (int a = 0; a < 8; ++a)
    for (int axis_bit = 1; axis_bit < 8; axis_bit <<= 1) {
      if (a & axis_bit) continue;
      const openvdb::Coord from = corner(a), to = corner(a | axis_bit);
      if ((surface.getValue(from) < 0) == (surface.getValue(to) < 0)) continue;
      if (!weights.isValueOn(from) || !weights.isValueOn(to)) return false;
      any = true;
    }
  return any;
}

// Trilinear interpolation at p over the corners of its cell that `observed` holds, renormalised: the
// background of unobserved corners (weight 0, colour black) would pull values at the band's edge down.
template <typename Value, typename Accessor>
Value observed_sample(const Accessor& values, const openvdb::FloatGrid::ConstAccessor& observed,
                      const openvdb::Vec3d& p) {
  const openvdb::Coord base(int(std::floor(p.x())), int(std::floor(p.y())), int(std::floor(p.z())));
  const openvdb::Vec3d f = p - base.asVec3d();
  Value sum = openvdb::zeroVal<Value>();
  double total = 0;
  for (int i = 0; i < 8; ++i) {
    const openvdb::Coord c = base.offsetBy(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    if (!observed.isValueOn(c)) continue;
    const double w = (i & 1 ? f.x() : 1 - f.x()) * (i & 2 ? f.y() : 1 - f.y()) * (i & 4 ? f.z() : 1 - f.z());
    sum += values.getValue(c) * float(w);
    total += w;
  }
  return total > 0 ? Value(sum * float(1 / total)) : sum;
}

}  // namespace

Mesh TsdfVolume::extract_mesh(const ExtractOptions& options) const {
  const Grids& g = *grids_;
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*g.surface, points, triangles, quads, 0.0, 0.0);
  const auto faces = triangles_from(points, triangles, quads);

  // A vertex is kept when its cell's zero crossings are all between observed voxels and its weight is
  // enough: elsewhere the crossing is between a measured distance and the unobserved background.
  // (Asking all eight corners to be observed, as marching cubes over weighted voxels does, also drops
  // cells at the edge of the observed band: Kinect frames at 10 mm agreed on 75.1% of their pixels
  // against 75.7%, the bunny's completeness p90 at 2 mm was 1.70 mm against 1.63.)
  const double inverse_voxel = 1.0 / voxel_size();
  std::vector<char> keep(points.size(), 0);
  std::vector<float> confidence(points.size(), 0.0f);
  std::vector<openvdb::Vec3s> colors(g.color ? points.size() : 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size()),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      auto weights = g.weight->getConstAccessor();
                      auto surface = g.surface->getConstAccessor();
                      std::optional<openvdb::Vec3SGrid::ConstAccessor> color_accessor;
                      std::optional<openvdb::FloatGrid::ConstAccessor> color_weights;
                      if (g.color) {
                        color_accessor.emplace(g.color->getConstAccessor());
                        color_weights.emplace(g.color_weight->getConstAccessor());
                      }
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        const openvdb::Vec3d index = openvdb::Vec3d(points[i]) * inverse_voxel;
                        if (!crossings_observed(surface, weights, index)) continue;
                        confidence[i] = observed_sample<float>(weights, weights, index);
                        if (confidence[i] < options.min_weight) continue;
                        keep[i] = 1;
                        if (color_accessor)
                          colors[i] = observed_sample<openvdb::Vec3s>(*color_accessor, *color_weights, index);
                      }
                    });

  Mesh mesh;
  std::vector<std::uint32_t> new_index(points.size(), UINT32_MAX);
  for (const auto& f : faces) {
    if (!keep[f[0]] || !keep[f[1]] || !keep[f[2]]) continue;
    std::array<std::uint32_t, 3> face;
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& index = new_index[f[k]];
      if (index == UINT32_MAX) {
        index = std::uint32_t(mesh.positions.size());
        const auto& p = points[f[k]];
        mesh.positions.emplace_back(p.x(), p.y(), p.z());
        mesh.vertex_properties["confidence"].push_back(confidence[f[k]]);
        if (g.color) {
          const auto& c = colors[f[k]];
          auto channel = [](float v) {
            return std::uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
          };
          mesh.colors.push_back({channel(c.x()), channel(c.y()), channel(c.z())});
        }
      }
      face[k] = index;
    }
    mesh.faces.push_back(face);
  }
  if (options.min_component_faces > 0 || options.min_component_fraction > 0)
    remove_small_components(mesh, options.min_component_faces, options.min_component_fraction);
  // Dropping unobserved cells can pinch the surface at a vertex; split those so the mesh is a manifold
  // that half-edge tools (pg-remesh) accept.
  split_nonmanifold_vertices(mesh);
  return mesh;
}

void TsdfVolume::write_vdb(const std::filesystem::path& path, const Provenance& provenance) const {
  const Grids& g = *grids_;
  openvdb::GridCPtrVec grids{g.surface, g.weight};
  if (g.color) {
    grids.push_back(g.color);
    grids.push_back(g.color_weight);
  }
  openvdb::MetaMap meta;
  meta.insertMeta("pg/format", openvdb::StringMetadata(vdb_format));
  meta.insertMeta("pg/version", openvdb::Int32Metadata(vdb_version));
  meta.insertMeta("pg/provenance", openvdb::StringMetadata(to_json(provenance).dump()));
  meta.insertMeta("pg/voxel_size", openvdb::DoubleMetadata(voxel_size()));
  meta.insertMeta("pg/truncation", openvdb::DoubleMetadata(truncation()));
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    try {
      openvdb::io::File file(tmp.string());
      file.write(grids, meta);
      file.close();
    } catch (const openvdb::Exception& e) {
      throw OutputError(path, e.what());
    }
  });
}

TsdfVolume TsdfVolume::read_vdb(const std::filesystem::path& path, Provenance* provenance) {
  initialize_openvdb();
  auto grids = std::make_unique<Grids>();
  try {
    openvdb::io::File file(path.string());
    file.open(false);  // no delayed loading: the file may be replaced while we run
    const auto meta = file.getMetadata();
    const auto format = meta->getMetadata<openvdb::StringMetadata>("pg/format");
    if (!format || format->value() != vdb_format)
      throw InputError(path, str("not a pg TSDF volume (metadata pg/format is not \"", vdb_format, "\")"));
    const auto version = meta->getMetadata<openvdb::Int32Metadata>("pg/version");
    if (!version || version->value() < 1 || version->value() > vdb_version)
      throw InputError(path, str("unsupported pg/version (this reader supports up to ", vdb_version, ")"));
    const auto voxel = meta->getMetadata<openvdb::DoubleMetadata>("pg/voxel_size");
    const auto truncation = meta->getMetadata<openvdb::DoubleMetadata>("pg/truncation");
    if (!voxel || !truncation || !(voxel->value() > 0) || !(truncation->value() >= voxel->value()))
      throw InputError(path, "missing or invalid pg/voxel_size or pg/truncation");
    if (provenance) {
      const auto text = meta->getMetadata<openvdb::StringMetadata>("pg/provenance");
      if (text) *provenance = provenance_from_json(nlohmann::json::parse(text->value()));
    }
    grids->options.voxel_size = voxel->value();
    grids->truncation = truncation->value();
    for (const char* name : {"surface", "weight"})
      if (!has_grid(file, name)) throw InputError(path, str("grid \"", name, "\" is missing"));
    grids->surface = float_grid(file, "surface", path);
    grids->weight = float_grid(file, "weight", path);
    if (has_grid(file, "Cd") && has_grid(file, "Cd_weight")) {
      grids->color = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("Cd"));
      if (!grids->color) throw InputError(path, "grid \"Cd\" is not a vec3s grid");
      grids->color_weight = float_grid(file, "Cd_weight", path);
      grids->options.color = true;
    }
    file.close();
  } catch (const openvdb::Exception& e) {
    throw InputError(path, str("cannot read the VDB file: ", e.what()));
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, str("pg/provenance is not valid JSON: ", e.what()));
  }
  const double voxel = grids->options.voxel_size;
  std::vector<openvdb::GridBase::ConstPtr> all{grids->surface, grids->weight};
  if (grids->color) all.insert(all.end(), {grids->color, grids->color_weight});
  for (const auto& grid : all) {
    const auto& transform = grid->transform();
    if (!transform.isLinear() || !transform.hasUniformScale() ||
        std::abs(transform.voxelSize()[0] - voxel) > 1e-9 * voxel ||
        transform.indexToWorld(openvdb::Vec3d(0, 0, 0)).length() > 1e-9 * voxel)
      throw InputError(path,
                       str("grid \"", grid->getName(), "\" does not use the volume's voxel size ", voxel));
  }
  return TsdfVolume(std::move(grids));
}

std::optional<float> TsdfVolume::distance_at(const Eigen::Vector3d& world) const {
  const openvdb::Vec3d index = openvdb::Vec3d(world.x(), world.y(), world.z()) / voxel_size();
  if (!cell_is_active(grids_->weight->getConstAccessor(), index)) return std::nullopt;
  return openvdb::tools::BoxSampler::sample(grids_->surface->getConstAccessor(), index);
}

float TsdfVolume::weight_at(const Eigen::Vector3d& world) const {
  const openvdb::Vec3d index = openvdb::Vec3d(world.x(), world.y(), world.z()) / voxel_size();
  return openvdb::tools::BoxSampler::sample(grids_->weight->getConstAccessor(), index);
}

TsdfVolume::Difference TsdfVolume::compare(const TsdfVolume& other) const {
  Difference difference;
  auto one_way = [&difference](const Grids& a, const Grids& b) {
    const auto b_weight = b.weight->getConstAccessor();
    const auto b_surface = b.surface->getConstAccessor();
    const auto a_surface = a.surface->getConstAccessor();
    for (auto v = a.weight->cbeginValueOn(); v; ++v) {
      const openvdb::Coord c = v.getCoord();
      if (!b_weight.isValueOn(c)) {
        difference.distance = difference.weight_relative = INFINITY;
        return;
      }
      difference.distance =
          std::max(difference.distance, double(std::abs(a_surface.getValue(c) - b_surface.getValue(c))));
      difference.weight_relative = std::max(
          difference.weight_relative, double(std::abs(*v - b_weight.getValue(c)) / std::max(*v, 1e-30f)));
    }
  };
  one_way(*grids_, *other.grids_);
  one_way(*other.grids_, *grids_);
  return difference;
}

}  // namespace pg::fusion
