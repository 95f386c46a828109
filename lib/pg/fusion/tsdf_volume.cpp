// Integration of frames, scans and partial volumes into the TSDF grids.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <mutex>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/fusion/tsdf_grids.h"
#include "pg/mesh/bvh.h"

namespace pg::fusion {
namespace {

using openvdb::Coord;
using openvdb::MaskTree;
constexpr int leaf_voxels = openvdb::FloatTree::LeafNodeType::SIZE;  // 512

// Calls visit(voxel) for every voxel whose cube (side one voxel around its centre) the segment
// from + s * direction, s in [0, length], crosses, in order along the segment, each once (Amanatides &
// Woo's traversal). World units; direction unit.
template <class Visit>
void for_each_crossed_voxel(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double length,
                            double inverse_voxel, Visit&& visit) {
  // Index space shifted by half a voxel, so that voxel i covers [i, i + 1) on each axis.
  const Eigen::Vector3d start = from * inverse_voxel + Eigen::Vector3d::Constant(0.5);
  const double end = length * inverse_voxel;
  Coord cell(int(std::floor(start.x())), int(std::floor(start.y())), int(std::floor(start.z())));
  int step[3];
  double next[3], delta[3];
  for (int a = 0; a < 3; ++a) {
    step[a] = direction[a] > 0 ? 1 : -1;
    const double boundary = cell[a] + (direction[a] > 0 ? 1 : 0);
    next[a] = direction[a] != 0 ? (boundary - start[a]) / direction[a] : INFINITY;
    delta[a] = direction[a] != 0 ? 1.0 / std::abs(direction[a]) : INFINITY;
  }
  for (;;) {
    visit(cell);
    const int a = next[0] <= next[1] ? (next[0] <= next[2] ? 0 : 2) : (next[1] <= next[2] ? 1 : 2);
    if (!(next[a] <= end)) return;
    cell[a] += step[a];
    next[a] += delta[a];
  }
}

// A mask tree whose destruction allocates nothing. OpenVDB's Tree::clear() gathers the nodes into
// vectors before freeing them, so a tree destroyed while std::bad_alloc unwinds (a run that reached
// its --max-memory address-space limit while marking) threw from a destructor: std::terminate
// instead of exit code 5. Deleting from the root down frees without allocating.
struct FreedMaskTree {
  MaskTree tree;
  FreedMaskTree() = default;
  FreedMaskTree(const FreedMaskTree&) = delete;
  FreedMaskTree& operator=(const FreedMaskTree&) = delete;
  ~FreedMaskTree() {
    tree.clearAllAccessors();
    tree.root().clear();
  }
};

// Marks the leaves that a segment of rays touches, one thread-local tree per worker, then unites them.
class LeafCollector {
  struct Local {
    std::unique_ptr<FreedMaskTree> mask = std::make_unique<FreedMaskTree>();
    openvdb::tree::ValueAccessor<MaskTree> accessor{mask->tree};
    void touchLeaf(const Coord& c) { accessor.setValueOn(c); }
  };

 public:
  explicit LeafCollector(double voxel_size) : inverse_voxel_(1.0 / voxel_size) {}

  // The marks of one worker thread: take one per task (finding the thread's tree is a table lookup,
  // too slow to repeat for every pixel).
  class Marker {
   public:
    Marker(Local& local, double inverse_voxel) : accessor(local), inverse_voxel_(inverse_voxel) {}

    // Marks every leaf holding the voxel nearest to some point of from + t * direction, t in [t0, t1]
    // (direction unit): the leaf cells the segment crosses, two or three per pixel's band instead of a
    // sample per voxel. for_each_crossed_voxel on the grid of leaves: voxel i covers [i - 1/2, i + 1/2)
    // voxels and leaf n the voxels [8n, 8n + 8), so the start moves by 3.5 voxels to put leaf n's
    // cube around its own centre.
    void touch_segment(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double t0, double t1) {
      constexpr int dim = openvdb::FloatTree::LeafNodeType::DIM;
      const Eigen::Vector3d start =
          from + direction * t0 - Eigen::Vector3d::Constant((dim / 2 - 0.5) / inverse_voxel_);
      for_each_crossed_voxel(start, direction, t1 - t0, inverse_voxel_ / dim, [&](const Coord& leaf) {
        accessor.touchLeaf(Coord(leaf.x() * dim, leaf.y() * dim, leaf.z() * dim));
      });
    }

    void touch_voxel(const Coord& voxel) { accessor.touchLeaf(voxel); }

   private:
    Local& accessor;
    double inverse_voxel_;
  };

  Marker marker() { return Marker(accessors_.local(), inverse_voxel_); }

  std::vector<Coord> leaf_origins() {
    FreedMaskTree all;
    for (auto& local : accessors_) all.tree.topologyUnion(local.mask->tree);
    std::vector<Coord> origins;
    origins.reserve(all.tree.leafCount());
    for (auto leaf = all.tree.cbeginLeaf(); leaf; ++leaf) origins.push_back(leaf->origin());
    return origins;
  }

 private:
  double inverse_voxel_;
  tbb::enumerable_thread_specific<Local> accessors_;
};

// Where a world point falls in a frame: the pixel it projects to, and its distance from the
// camera centre along that pixel's ray.
struct FrameProjector {
  const DepthFrame& frame;
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  bool plain_pinhole;
  double fx, fy, cx, cy;

  explicit FrameProjector(const DepthFrame& f)
      : frame(f),
        rotation(f.camera.cam_from_world.rotation_matrix()),
        translation(f.camera.cam_from_world.translation),
        plain_pinhole(f.camera.model == CameraModel::pinhole && f.camera.distortion.is_zero()),
        fx(f.camera.intrinsics.fx),
        fy(f.camera.intrinsics.fy),
        cx(f.camera.intrinsics.cx),
        cy(f.camera.intrinsics.cy) {}

  // The signed distance along the ray (positive in front of the measured surface) and the pixel;
  // false when the point does not land on a valid, weighted pixel.
  bool sample(const Eigen::Vector3d& world, double& distance, int& px, int& py) const {
    const Eigen::Vector3d p = rotation * world + translation;
    Eigen::Vector2d pixel;
    if (plain_pinhole) {
      if (p.z() <= 0) return false;
      pixel = {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
    } else if (!frame.camera.project(p, pixel)) {
      return false;
    }
    // Pixel (px, py) covers [px - 1/2, px + 1/2): inside the image its rounding is the truncation of a
    // positive number (cheaper than std::floor without SSE4.1, and this runs for every voxel).
    if (!(pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() < frame.depth.cols - 0.5 &&
          pixel.y() < frame.depth.rows - 0.5))
      return false;
    px = int(pixel.x() + 0.5);
    py = int(pixel.y() + 0.5);
    if (!(frame.weight(py, px) > 0)) return false;
    const float d = frame.depth(py, px);
    if (!std::isfinite(d)) return false;
    const double range = p.norm();
    if (frame.kind == DepthKind::perspective_z) {
      if (p.z() <= 0) return false;
      distance = range * (d / p.z() - 1.0);  // the z difference, scaled to a distance along the ray
    } else {
      distance = d - range;
    }
    return true;
  }
};

openvdb::Vec3s linear_color(const cv::Vec3b& bgr) {
  return openvdb::Vec3s(bgr[2] / 255.0f, bgr[1] / 255.0f, bgr[0] / 255.0f);
}

openvdb::Vec3s linear_color(const std::array<std::uint8_t, 3>& rgb) {
  return openvdb::Vec3s(rgb[0] / 255.0f, rgb[1] / 255.0f, rgb[2] / 255.0f);
}

}  // namespace

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

TsdfVolume::TsdfVolume(const TsdfOptions& options) : grids_(std::make_unique<Grids>()) {
  if (!(options.voxel_size > 0) || !std::isfinite(options.voxel_size))
    throw UsageError(str("the voxel size must be positive, not ", options.voxel_size));
  if (options.truncation < 0) throw UsageError("the truncation must not be negative");
  initialize_openvdb();
  Grids& g = *grids_;
  g.options = options;
  g.truncation = options.truncation > 0 ? options.truncation : 4 * options.voxel_size;
  if (!(g.truncation >= options.voxel_size && g.truncation <= max_truncation_voxels * options.voxel_size))
    throw UsageError(str("the truncation (", g.truncation, ") must be from one to ", max_truncation_voxels,
                         " voxels (", options.voxel_size, ")"));
  const auto transform = openvdb::math::Transform::createLinearTransform(options.voxel_size);
  g.surface = openvdb::FloatGrid::create(float(g.truncation));
  g.surface->setName("surface");
  g.surface->setGridClass(openvdb::GRID_LEVEL_SET);
  g.surface->setTransform(transform);
  g.weight = openvdb::FloatGrid::create(0.0f);
  g.weight->setName("weight");
  g.weight->setTransform(transform->copy());
  if (options.color) {
    g.color = openvdb::Vec3SGrid::create(openvdb::Vec3s(0, 0, 0));
    g.color->setName("Cd");
    g.color->setTransform(transform->copy());
    g.color_weight = openvdb::FloatGrid::create(0.0f);
    g.color_weight->setName("Cd_weight");
    g.color_weight->setTransform(transform->copy());
  }
}

TsdfVolume::TsdfVolume(std::unique_ptr<Grids> grids) : grids_(std::move(grids)) {}
TsdfVolume::~TsdfVolume() = default;
TsdfVolume::TsdfVolume(TsdfVolume&&) noexcept = default;
TsdfVolume& TsdfVolume::operator=(TsdfVolume&&) noexcept = default;

double TsdfVolume::voxel_size() const {
  return grids_->options.voxel_size;
}
double TsdfVolume::truncation() const {
  return grids_->truncation;
}
bool TsdfVolume::has_color() const {
  return bool(grids_->color);
}
std::size_t TsdfVolume::leaf_count() const {
  return grids_->surface->tree().leafCount();
}
std::uint64_t TsdfVolume::active_voxel_count() const {
  return grids_->weight->activeVoxelCount();
}
std::uint64_t TsdfVolume::memory_bytes() const {
  std::uint64_t bytes = grids_->surface->memUsage() + grids_->weight->memUsage();
  if (grids_->color) bytes += grids_->color->memUsage() + grids_->color_weight->memUsage();
  return bytes;
}

namespace {

// Bytes one leaf, one lower (16^3 leaves) and one upper (32^3 lower nodes) internal node of a tree take.
template <class TreeT>
std::array<std::uint64_t, 3> node_bytes() {
  using Upper = typename TreeT::RootNodeType::ChildNodeType;
  using Lower = typename Upper::ChildNodeType;
  using Leaf = typename TreeT::LeafNodeType;
  return {sizeof(Leaf) + Leaf::SIZE * sizeof(typename TreeT::ValueType), sizeof(Lower), sizeof(Upper)};
}

// The number of distinct keys, each origin rounded down to a multiple of `dim` voxels, for which
// `exists` is false.
template <class Exists>
std::size_t count_new_parents(const std::vector<Coord>& origins, int dim, Exists&& exists) {
  std::vector<Coord> keys;
  keys.reserve(origins.size());
  for (const Coord& o : origins) keys.push_back(o & ~(dim - 1));
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return std::size_t(std::count_if(keys.begin(), keys.end(), [&](const Coord& k) { return !exists(k); }));
}

// Bytes the grids would grow by to hold the leaves at `origins`: the leaves that are not there yet
// and the internal nodes that would be new above them.
std::uint64_t growth_bytes(const TsdfVolume::Grids& g, const std::vector<Coord>& origins) {
  const openvdb::FloatTree& tree = g.surface->tree();
  using Upper = openvdb::FloatTree::RootNodeType::ChildNodeType;
  using Lower = Upper::ChildNodeType;
  std::vector<Coord> new_leaves;
  for (const Coord& origin : origins)
    if (!tree.probeConstLeaf(origin)) new_leaves.push_back(origin);
  // At a small voxel size every leaf may need internal nodes of its own, each ten times its size.
  const std::uint64_t counts[3] = {
      new_leaves.size(),
      count_new_parents(new_leaves, Lower::DIM,
                        [&](const Coord& k) { return tree.probeConstNode<Lower>(k); }),
      count_new_parents(new_leaves, Upper::DIM,
                        [&](const Coord& k) { return tree.probeConstNode<Upper>(k); })};
  const auto scalar = node_bytes<openvdb::FloatTree>();
  const auto vector = node_bytes<openvdb::Vec3STree>();
  std::uint64_t bytes = 0;
  for (int level = 0; level < 3; ++level)
    bytes += counts[level] * (2 * scalar[level] + (g.color ? vector[level] + scalar[level] : 0));
  return bytes;
}

// Error(out_of_memory) before allocating when the grids would exceed their budget.
void check_memory(const TsdfVolume& volume, const TsdfVolume::Grids& g, const std::vector<Coord>& origins,
                  const std::string& input) {
  const std::uint64_t limit = g.options.max_memory;
  if (limit == 0) return;
  const std::uint64_t needed = volume.memory_bytes() + growth_bytes(g, origins);
  if (needed > limit)
    throw Error(ExitCode::out_of_memory,
                str("merging ", input, " at voxel size ", g.options.voxel_size, " needs about ",
                    needed / (1 << 20), " MiB for the grids, more than --max-memory ", limit / (1 << 20),
                    " MiB (use a larger voxel size or more memory)"));
}

// Creates the leaves (in every grid) that are not there yet; returns how many were new.
std::size_t allocate_leaves(TsdfVolume::Grids& g, const std::vector<Coord>& origins) {
  std::size_t created = 0;
  for (const Coord& origin : origins) {
    if (g.surface->tree().probeConstLeaf(origin)) continue;
    ++created;
    g.surface->tree().touchLeaf(origin);
    g.weight->tree().touchLeaf(origin);
    if (g.color) {
      g.color->tree().touchLeaf(origin);
      g.color_weight->tree().touchLeaf(origin);
    }
  }
  return created;
}

// Leaves that received no sample are returned to the background so memory follows the surface.
void drop_empty_leaves(TsdfVolume::Grids& g, const std::vector<Coord>& origins) {
  for (const Coord& origin : origins) {
    const auto* leaf = g.weight->tree().probeConstLeaf(origin);
    if (!leaf || !leaf->isEmpty()) continue;
    g.surface->tree().addTile(1, origin, g.surface->background(), false);
    g.weight->tree().addTile(1, origin, 0.0f, false);
    if (g.color) {
      g.color->tree().addTile(1, origin, openvdb::Vec3s(0, 0, 0), false);
      g.color_weight->tree().addTile(1, origin, 0.0f, false);
    }
  }
}

struct LeafSet {
  openvdb::FloatTree::LeafNodeType* surface;
  openvdb::FloatTree::LeafNodeType* weight;
  openvdb::Vec3STree::LeafNodeType* color;
  openvdb::FloatTree::LeafNodeType* color_weight;
};

LeafSet leaves_at(TsdfVolume::Grids& g, const Coord& origin) {
  return {g.surface->tree().probeLeaf(origin), g.weight->tree().probeLeaf(origin),
          g.color ? g.color->tree().probeLeaf(origin) : nullptr,
          g.color_weight ? g.color_weight->tree().probeLeaf(origin) : nullptr};
}

// The running weighted mean of Curless & Levoy: D = (W D + w d) / (W + w), W = W + w.
inline void accumulate(LeafSet& leaves, int n, float distance, float w) {
  const float w0 = leaves.weight->isValueOn(n) ? leaves.weight->getValue(n) : 0.0f;
  const float d0 = w0 > 0 ? leaves.surface->getValue(n) : 0.0f;
  const float w1 = w0 + w;
  leaves.surface->setValueOn(n, (d0 * w0 + distance * w) / w1);
  leaves.weight->setValueOn(n, w1);
}

inline void accumulate_color(LeafSet& leaves, int n, const openvdb::Vec3s& color, float w) {
  const float w0 = leaves.color_weight->isValueOn(n) ? leaves.color_weight->getValue(n) : 0.0f;
  const openvdb::Vec3s c0 = w0 > 0 ? leaves.color->getValue(n) : openvdb::Vec3s(0, 0, 0);
  const float w1 = w0 + w;
  leaves.color->setValueOn(n, (c0 * w0 + color * w) / w1);
  leaves.color_weight->setValueOn(n, w1);
}

// One scan point's ray: unit direction, weight (multiplier, confidence, angle) and the cos of the
// angle between its normal and the ray (1 without a normal) that measures the depth behind it.
struct PointRay {
  Eigen::Vector3d direction;
  double weight = 0, cos_angle = 1;
};

// False for a point that gives no samples (not finite, at its origin, beyond max_range, no
// confidence, too grazing).
bool point_ray(const ScanPoints& scan, std::size_t i, PointRay& ray) {
  const Eigen::Vector3d& p = scan.positions[i];
  if (!p.allFinite()) return false;
  if (scan.sensor_direction) {
    ray.direction = *scan.sensor_direction;
  } else {
    const Eigen::Vector3d v = p - (scan.origins.empty() ? *scan.sensor_origin : scan.origins[i]);
    const double range = v.norm();
    if (!(range > 0) || !std::isfinite(range)) return false;
    if (scan.max_range > 0 && range > scan.max_range) return false;
    ray.direction = v / range;
  }
  ray.weight = scan.multiplier;
  if (scan.use_confidence && !scan.confidence.empty()) {
    if (!(scan.confidence[i] > 0)) return false;
    ray.weight *= scan.confidence[i];
  }
  ray.cos_angle = 1;
  if (!scan.normals.empty()) {
    const double cos_angle = std::abs(scan.normals[i].cast<double>().dot(ray.direction));
    if (std::isfinite(cos_angle)) {
      if (scan.use_angle && cos_angle < scan.min_cos) return false;
      if (scan.use_angle) ray.weight *= cos_angle;
      ray.cos_angle = std::max(cos_angle, min_band_cos);
    }
  }
  return true;
}

void check_scan_points(const ScanPoints& scan) {
  const std::size_t n = scan.positions.size();
  auto sized = [n](std::size_t size) { return size == 0 || size == n; };
  if (!sized(scan.origins.size()) || !sized(scan.normals.size()) || !sized(scan.confidence.size()) ||
      !sized(scan.colors.size()))
    throw Error(ExitCode::internal, str(scan.name, ": scan point attributes differ in size"));
  const int sensors = int(!scan.origins.empty()) + int(scan.sensor_origin.has_value()) +
                      int(scan.sensor_direction.has_value());
  if (sensors != 1)
    throw UsageError(str(scan.name,
                         ": scan points need exactly one of per-point origins, a sensor origin "
                         "or a sensor direction"));
}

}  // namespace

void TsdfVolume::integrate(const DepthFrame& frame) {
  Grids& g = *grids_;
  const double truncation = g.truncation;
  const double voxel = voxel_size();
  const Rigid3 world_from_cam = frame.camera.cam_from_world.inverse();
  const Eigen::Matrix3d world_rotation = world_from_cam.rotation_matrix();
  const Eigen::Vector3d centre = world_from_cam.translation;
  if (frame.depth.size() != frame.weight.size() ||
      (!frame.color.empty() && frame.color.size() != frame.depth.size()))
    throw FailedError(str(frame.name, ": depth, weight and colour sizes differ"));

  LeafCollector collector(voxel);
  tbb::parallel_for(tbb::blocked_range<int>(0, frame.depth.rows), [&](const tbb::blocked_range<int>& rows) {
    LeafCollector::Marker marker = collector.marker();
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < frame.depth.cols; ++x) {
        const float d = frame.depth(y, x);
        if (!(frame.weight(y, x) > 0) || !std::isfinite(d)) continue;
        const Eigen::Vector3d ray = frame.camera.unproject(Eigen::Vector2d(x, y));
        const double range = frame.kind == DepthKind::perspective_z ? d / ray.z() : d;
        marker.touch_segment(centre, world_rotation * ray, std::max(0.0, range - truncation),
                             range + truncation);
      }
  });
  const std::vector<Coord> origins = collector.leaf_origins();
  check_memory(*this, g, origins, frame.name);
  allocate_leaves(g, origins);

  // The accelerated device integrates a prefix of the leaves (all of them, or none where it is not
  // used; fewer after a device failure); the CPU integrates the rest.
  const std::size_t on_device = integrate_on_device(g, origins, frame);
  const FrameProjector projector(frame);
  const bool with_color = g.color && !frame.color.empty();
  const cv::Mat3b color = frame.color;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(on_device, origins.size()),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        LeafSet leaves = leaves_at(g, origins[i]);
                        for (int n = 0; n < leaf_voxels; ++n) {
                          const Coord c = leaves.surface->offsetToGlobalCoord(n);
                          const Eigen::Vector3d world(c.x() * voxel, c.y() * voxel, c.z() * voxel);
                          double distance;
                          int px, py;
                          if (!projector.sample(world, distance, px, py)) continue;
                          // Behind the surface only as deep as the band, measured across the surface (not
                          // along the ray, which would leave grazing surfaces with a band too thin to hold
                          // both signs). Behind the surface the weight ramps down to zero at the band's end
                          // (Curless & Levoy).
                          const double cos_angle = frame.cos_angle.empty() ? 1.0 : frame.cos_angle(py, px);
                          const double depth_behind = -std::min(0.0, distance * cos_angle);
                          if (depth_behind >= truncation) continue;
                          const float w = float(frame.weight(py, px) * (1.0 - depth_behind / truncation));
                          accumulate(leaves, n, float(std::clamp(distance, -truncation, truncation)), w);
                          if (with_color) accumulate_color(leaves, n, linear_color(color(py, px)), w);
                        }
                      }
                    });
  drop_empty_leaves(g, origins);
}

void TsdfVolume::integrate(const ScanSurface& scan) {
  Grids& g = *grids_;
  const double truncation = g.truncation;
  const double voxel = voxel_size();
  const Mesh& mesh = scan.mesh;
  if (scan.sensor_origin.has_value() == scan.sensor_direction.has_value())
    throw UsageError(str(scan.name, ": a scan needs exactly one of a sensor origin or direction"));
  auto ray_direction = [&](const Eigen::Vector3d& point) -> Eigen::Vector3d {
    return scan.sensor_direction ? *scan.sensor_direction
                                 : Eigen::Vector3d((point - *scan.sensor_origin).normalized());
  };

  // Touch the band along the sensor ray through points spread over every triangle (at most a voxel apart).
  LeafCollector collector(voxel);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, mesh.faces.size()), [&](const tbb::blocked_range<std::size_t>& r) {
        LeafCollector::Marker marker = collector.marker();
        for (std::size_t f = r.begin(); f < r.end(); ++f) {
          const Eigen::Vector3d a = mesh.positions[mesh.faces[f][0]].cast<double>();
          const Eigen::Vector3d b = mesh.positions[mesh.faces[f][1]].cast<double>();
          const Eigen::Vector3d c = mesh.positions[mesh.faces[f][2]].cast<double>();
          const double longest = std::max({(a - b).norm(), (b - c).norm(), (c - a).norm()});
          const int steps = std::max(1, int(std::ceil(longest / voxel)));
          for (int i = 0; i <= steps; ++i)
            for (int j = 0; i + j <= steps; ++j) {
              const Eigen::Vector3d p = a + (b - a) * (double(i) / steps) + (c - a) * (double(j) / steps);
              const Eigen::Vector3d direction = ray_direction(p);
              marker.touch_segment(p, direction, -truncation, truncation);
            }
        }
      });
  const std::vector<Coord> origins = collector.leaf_origins();
  check_memory(*this, g, origins, scan.name);
  allocate_leaves(g, origins);

  const TriangleBvh bvh(mesh);
  std::vector<Eigen::Vector3d> face_normals(mesh.faces.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Eigen::Vector3d a = mesh.positions[mesh.faces[f][0]].cast<double>();
    const Eigen::Vector3d b = mesh.positions[mesh.faces[f][1]].cast<double>();
    const Eigen::Vector3d c = mesh.positions[mesh.faces[f][2]].cast<double>();
    face_normals[f] = (b - a).cross(c - a).normalized();
  }
  const bool with_color = g.color && mesh.colors.size() == mesh.positions.size();
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, origins.size()), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
          LeafSet leaves = leaves_at(g, origins[i]);
          for (int n = 0; n < leaf_voxels; ++n) {
            const Coord c = leaves.surface->offsetToGlobalCoord(n);
            const Eigen::Vector3d world(c.x() * voxel, c.y() * voxel, c.z() * voxel);
            const Eigen::Vector3d direction = ray_direction(world);
            // The first surface along the ray, starting one truncation towards the sensor.
            const Eigen::Vector3d start = world - direction * truncation;
            const TriangleBvh::RayHit hit =
                bvh.intersect(start.cast<float>(), direction.cast<float>(), float(2 * truncation));
            if (!hit.hit) continue;
            const double cos_angle = std::abs(face_normals[hit.face].dot(direction));
            if (!(cos_angle >= scan.min_cos)) continue;
            const float w = float(cos_angle * scan.multiplier);
            accumulate(leaves, n, float(hit.t - truncation), w);
            if (with_color) {
              const auto& face = mesh.faces[hit.face];
              const openvdb::Vec3s color = linear_color(mesh.colors[face[0]]) * (1 - hit.b1 - hit.b2) +
                                           linear_color(mesh.colors[face[1]]) * hit.b1 +
                                           linear_color(mesh.colors[face[2]]) * hit.b2;
              accumulate_color(leaves, n, color, w);
            }
          }
        }
      });
  drop_empty_leaves(g, origins);
}

void TsdfVolume::integrate(const ScanPoints& scan) {
  check_scan_points(scan);
  Grids& g = *grids_;
  const double truncation = g.truncation;
  const double inverse_voxel = 1.0 / voxel_size();
  const std::size_t count = scan.positions.size();

  std::vector<PointRay> rays(count);
  std::vector<std::uint8_t> used(count, 0);
  LeafCollector collector(voxel_size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count), [&](const tbb::blocked_range<std::size_t>& r) {
    LeafCollector::Marker marker = collector.marker();
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      if (!point_ray(scan, i, rays[i])) continue;
      used[i] = 1;
      const Eigen::Vector3d start = scan.positions[i] - rays[i].direction * truncation;
      Coord last_leaf = Coord::max();
      for_each_crossed_voxel(start, rays[i].direction, 2 * truncation, inverse_voxel, [&](const Coord& c) {
        const Coord leaf = c & ~(openvdb::FloatTree::LeafNodeType::DIM - 1);
        if (leaf != last_leaf) marker.touch_voxel(leaf);
        last_leaf = leaf;
      });
    }
  });
  const std::vector<Coord> origins = collector.leaf_origins();
  check_memory(*this, g, origins, scan.name);
  allocate_leaves(g, origins);

  // One thread, points in input order: the running means come out the same bits at any thread count.
  const double voxel = voxel_size();
  openvdb::FloatGrid::Accessor surface = g.surface->getAccessor(), weight = g.weight->getAccessor();
  const bool with_color = g.color && !scan.colors.empty();
  for (std::size_t i = 0; i < count; ++i) {
    if (!used[i]) continue;
    const PointRay& ray = rays[i];
    const Eigen::Vector3d& p = scan.positions[i];
    const double along_point = p.dot(ray.direction);
    const Eigen::Vector3d start = p - ray.direction * truncation;
    Coord leaf_origin = Coord::max();
    LeafSet leaves{};
    for_each_crossed_voxel(start, ray.direction, 2 * truncation, inverse_voxel, [&](const Coord& c) {
      const Coord origin = c & ~(openvdb::FloatTree::LeafNodeType::DIM - 1);
      if (origin != leaf_origin) {
        leaves.surface = surface.probeLeaf(c);
        leaves.weight = weight.probeLeaf(c);
        if (with_color) {
          leaves.color = g.color->tree().probeLeaf(c);
          leaves.color_weight = g.color_weight->tree().probeLeaf(c);
        }
        leaf_origin = origin;
      }
      // Positive in front of the point (towards the sensor), along the ray.
      const double distance = along_point - Eigen::Vector3d(c.x(), c.y(), c.z()).dot(ray.direction) * voxel;
      const double depth_behind = -std::min(0.0, distance * ray.cos_angle);
      if (depth_behind >= truncation) return;
      const float w = float(ray.weight * (1.0 - depth_behind / truncation));
      const int n = int(openvdb::FloatTree::LeafNodeType::coordToOffset(c));
      accumulate(leaves, n, float(std::clamp(distance, -truncation, truncation)), w);
      if (with_color) accumulate_color(leaves, n, linear_color(scan.colors[i]), w);
    });
  }
  drop_empty_leaves(g, origins);
}

void TsdfVolume::merge_partial(const TsdfVolume& partial) {
  Grids& g = *grids_;
  const Grids& p = *partial.grids_;
  if (std::abs(p.options.voxel_size - g.options.voxel_size) > 1e-12 * g.options.voxel_size ||
      std::abs(p.truncation - g.truncation) > 1e-12 * g.truncation)
    throw UsageError(str("partial volumes differ: voxel size ", p.options.voxel_size, " vs ",
                         g.options.voxel_size, ", truncation ", p.truncation, " vs ", g.truncation));
  std::vector<Coord> origins;
  for (auto leaf = p.weight->tree().cbeginLeaf(); leaf; ++leaf) origins.push_back(leaf->origin());
  check_memory(*this, g, origins, "a partial volume");
  allocate_leaves(g, origins);
  const bool with_color = g.color && p.color;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, origins.size()),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        LeafSet leaves = leaves_at(g, origins[i]);
                        const auto* weight = p.weight->tree().probeConstLeaf(origins[i]);
                        const auto* surface = p.surface->tree().probeConstLeaf(origins[i]);
                        for (auto v = weight->cbeginValueOn(); v; ++v) {
                          const int n = int(v.pos());
                          accumulate(leaves, n, surface->getValue(n), *v);
                        }
                        if (!with_color) continue;
                        const auto* color_weight = p.color_weight->tree().probeConstLeaf(origins[i]);
                        const auto* color = p.color->tree().probeConstLeaf(origins[i]);
                        if (!color_weight || !color) continue;
                        for (auto v = color_weight->cbeginValueOn(); v; ++v)
                          accumulate_color(leaves, int(v.pos()), color->getValue(v.pos()), *v);
                      }
                    });
  drop_empty_leaves(g, origins);
}

}  // namespace pg::fusion
