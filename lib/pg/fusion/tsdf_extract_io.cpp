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

// A zero crossing between voxels a and b is a measured surface when both were observed and their
// distances differ by at most `max_jump`. An unobserved voxel holds the background (+truncation), so a
// crossing towards it is the back of a frame's band, not a surface; a larger step is the back of one
// frame's band against the free space another frame saw.
struct Crossing {
  const openvdb::FloatGrid::ConstAccessor& surface;
  const openvdb::FloatGrid::ConstAccessor& weights;
  double max_jump;
  bool crosses(const openvdb::Coord& a, const openvdb::Coord& b) const {
    return (surface.getValue(a) < 0) != (surface.getValue(b) < 0);
  }
  bool measured(const openvdb::Coord& a, const openvdb::Coord& b) const {
    return weights.isValueOn(a) && weights.isValueOn(b) &&
           std::abs(double(surface.getValue(a)) - double(surface.getValue(b))) <= max_jump;
  }
};

// The zero crossings on the edges of a cell: how many, how many measured, whether all are, and the
// mean of the measured ones' points (index space, linear along each edge).
struct CellCrossings {
  int total = 0, measured = 0;
  bool all_measured = true;
  openvdb::Vec3d measured_mean{0, 0, 0};
};

CellCrossings cell_crossings(const Crossing& crossing, const openvdb::Coord& cell) {
  auto corner = [&](int i) { return cell.offsetBy(i & 1, (i >> 1) & 1, (i >> 2) & 1); };
  CellCrossings result;
  for (int a = 0; a < 8; ++a)
    for (int axis_bit = 1; axis_bit < 8; axis_bit <<= 1) {
      if (a & axis_bit) continue;
      const openvdb::Coord from = corner(a), to = corner(a | axis_bit);
      if (!crossing.crosses(from, to)) continue;
      ++result.total;
      if (!crossing.measured(from, to)) {
        result.all_measured = false;
        continue;
      }
      ++result.measured;
      const double d0 = crossing.surface.getValue(from), d1 = crossing.surface.getValue(to);
      result.measured_mean += from.asVec3d() + (to.asVec3d() - from.asVec3d()) * (d0 / (d0 - d1));
    }
  if (result.measured > 0) result.measured_mean *= 1.0 / result.measured;
  return result;
}

// The cell of a volumeToMesh vertex (index space) and its crossings. A vertex lies inside the cell
// whose edge crossings placed it, but one on a cell's face (a zero distance stored exactly on a
// voxel, as a surface on a voxel layer gives) floors into the neighbour: of the cells it touches,
// the first with a crossing is its own.
struct VertexCell {
  openvdb::Coord cell;
  CellCrossings crossings;
};

VertexCell vertex_cell(const Crossing& crossing, const openvdb::Vec3d& p) {
  constexpr double on_face = 1e-4;
  const openvdb::Coord base(int(std::floor(p.x())), int(std::floor(p.y())), int(std::floor(p.z())));
  openvdb::Coord step;  // per axis: the neighbour's side when p lies on a face of the cell, else 0
  for (int k = 0; k < 3; ++k) {
    const double f = p[k] - base[k];
    step[k] = f < on_face ? -1 : (f > 1 - on_face ? 1 : 0);
  }
  VertexCell first{base, cell_crossings(crossing, base)};
  for (int mask = 1; first.crossings.total == 0 && mask < 8; ++mask) {
    openvdb::Coord cell = base;
    bool valid = true;
    for (int k = 0; k < 3; ++k)
      if (mask & (1 << k)) valid &= step[k] != 0, cell[k] += step[k];
    if (!valid) continue;
    const CellCrossings crossings = cell_crossings(crossing, cell);
    if (crossings.total > 0) first = {cell, crossings};
  }
  return first;
}

// The grid edge a quad of volumeToMesh is dual to: its four vertices lie in the four cells around the
// edge, which share their index along the edge's axis and take two values on each other axis (the
// edge sits at the larger). False when the cells do not show that pattern.
bool dual_edge(const std::array<openvdb::Coord, 4>& cells, openvdb::Coord& from, openvdb::Coord& to) {
  int axis = -1;
  for (int k = 0; k < 3; ++k) {
    const bool shared =
        cells[1][k] == cells[0][k] && cells[2][k] == cells[0][k] && cells[3][k] == cells[0][k];
    if (shared) {
      if (axis >= 0) return false;
      axis = k;
    }
  }
  if (axis < 0) return false;
  for (int k = 0; k < 3; ++k) {
    int low = cells[0][k], high = cells[0][k];
    for (const openvdb::Coord& c : cells) low = std::min(low, c[k]), high = std::max(high, c[k]);
    if (k != axis && high != low + 1) return false;
    from[k] = high;
  }
  to = from;
  to[axis] += 1;
  return true;
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

  // The surface is kept where the distance crosses zero between two observed voxels by a step a
  // surface can make. Each quad is dual to one grid edge and is kept when that edge's two voxels are
  // observed and their distances differ by at most 1.5 truncations. Elsewhere the crossing is the
  // back of a frame's band: against the unobserved background (+truncation), or, by a step of about
  // two truncations, against the free space another frame saw in front of its own surface. (A
  // distance along a grazing ray changes by up to twice the voxel per voxel, far below that.)
  // A vertex is kept where any crossing of its cell is measured, and placed at the mean of those
  // where some are not; triangles volumeToMesh emits itself keep the stricter rule of every crossing
  // of each vertex's cell measured. The old rule, every crossing of each vertex's cell observed,
  // dropped every face around cells that hold the back of a band beside the surface: Kinect frames
  // at 10 mm agreed on 75.7% of their pixels (now 80.5%, Open3D 78.1%), the bunny's completeness p90
  // at 2 mm was 1.63 mm (now 1.30, Open3D 1.35), with accuracy p90 0.42 mm (now 0.415, Open3D 0.54).
  // Without the step limit, surfaces only ever seen from behind other surfaces doubled (Kinect at
  // 4 mm, 5.5% of the faces against 2.9%). Left where volumeToMesh put them, vertices beside the back
  // of a band leaned towards it (0.7 voxels off a floor seen once; the Kinect frames agreed on 82.0%,
  // the bunny's completeness p90 was 1.16 mm and its accuracy p90 0.43 mm).
  const double max_jump = 1.5 * truncation();
  const double inverse_voxel = 1.0 / voxel_size();
  std::vector<char> keep(points.size(), 0), strict(points.size(), 0);
  std::vector<openvdb::Coord> cells(points.size());
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
                      const Crossing crossing{surface, weights, max_jump};
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        openvdb::Vec3d index = openvdb::Vec3d(points[i]) * inverse_voxel;
                        const auto [cell, crossings] = vertex_cell(crossing, index);
                        cells[i] = cell;
                        if (crossings.measured == 0) continue;
                        // volumeToMesh placed the vertex at the mean of all its cell's crossings:
                        // where some are not surfaces, the mean of the measured ones.
                        if (!crossings.all_measured) {
                          index = crossings.measured_mean;
                          points[i] = openvdb::Vec3s(index * voxel_size());
                        }
                        confidence[i] = observed_sample<float>(weights, weights, index);
                        if (confidence[i] < options.min_weight) continue;
                        keep[i] = 1;
                        strict[i] = crossings.all_measured;
                        if (color_accessor)
                          colors[i] = observed_sample<openvdb::Vec3s>(*color_accessor, *color_weights, index);
                      }
                    });
  std::vector<char> keep_face(faces.size(), 0);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, quads.size()), [&](const tbb::blocked_range<std::size_t>& r) {
        auto weights = g.weight->getConstAccessor();
        auto surface = g.surface->getConstAccessor();
        const Crossing crossing{surface, weights, max_jump};
        for (std::size_t q = r.begin(); q < r.end(); ++q) {
          const openvdb::Vec4I& quad = quads[q];
          bool kept = keep[quad[0]] && keep[quad[1]] && keep[quad[2]] && keep[quad[3]];
          if (kept) {
            const std::array<openvdb::Coord, 4> around{cells[quad[0]], cells[quad[1]], cells[quad[2]],
                                                       cells[quad[3]]};
            openvdb::Coord from, to;
            kept = dual_edge(around, from, to) && crossing.crosses(from, to)
                       ? crossing.measured(from, to)
                       : strict[quad[0]] && strict[quad[1]] && strict[quad[2]] && strict[quad[3]];
          }
          keep_face[triangles.size() + 2 * q] = keep_face[triangles.size() + 2 * q + 1] = kept;
        }
      });
  for (std::size_t t = 0; t < triangles.size(); ++t)
    keep_face[t] = strict[faces[t][0]] && strict[faces[t][1]] && strict[faces[t][2]];

  Mesh mesh;
  std::vector<std::uint32_t> new_index(points.size(), UINT32_MAX);
  for (std::size_t i = 0; i < faces.size(); ++i) {
    if (!keep_face[i]) continue;
    const auto& f = faces[i];
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
    if (!voxel || !truncation || !(voxel->value() > 0) || !(truncation->value() >= voxel->value()) ||
        !(truncation->value() <= max_truncation_voxels * voxel->value()))
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
  // write_vdb writes voxels in leaves only, the surface's where the weight's are (and the colour's
  // where its weight's are); merging and extraction rely on it.
  const auto covers = [&](const auto& values, const auto& weights, const char* name) {
    if (weights->tree().activeTileCount() > 0)
      throw InputError(path, str("grid \"", weights->getName(), "\" has active tiles"));
    for (auto leaf = weights->tree().cbeginLeaf(); leaf; ++leaf)
      if (!values->tree().probeConstLeaf(leaf->origin()))
        throw InputError(path,
                         str("grid \"", name, "\" lacks voxels that grid \"", weights->getName(), "\" has"));
  };
  covers(grids->surface, grids->weight, "surface");
  if (grids->color) covers(grids->color, grids->color_weight, "Cd");
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

bool TsdfVolume::vdb_has_color(const std::filesystem::path& path) {
  initialize_openvdb();
  try {
    openvdb::io::File file(path.string());
    file.open(false);
    const bool color = has_grid(file, "Cd") && has_grid(file, "Cd_weight");
    file.close();
    return color;
  } catch (const openvdb::Exception& e) {
    throw InputError(path, str("cannot read the VDB file: ", e.what()));
  }
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
