#pragma once
// Exact CPU rasterizer for every camera model. Each pixel's ray (RayTable) is tested against each
// candidate triangle with the three edge planes through the camera centre: the normalised signed
// distances to those planes are the perspective-correct barycentrics, and the hit distance along the
// ray is the depth. Candidates come from conservative per-triangle pixel boxes binned into tiles;
// tiles render in parallel and each owns its pixels, so results are bit-identical for any thread count.
// Shared edges are watertight: an edge's plane is computed identically for both triangles, and a ray
// exactly on it belongs to exactly one of them.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/mesh/mesh.h"
#include "pg/render/ray_table.h"
#include "pg/render/texture.h"

namespace pg {

inline constexpr std::uint32_t kNoTriangle = std::numeric_limits<std::uint32_t>::max();

// z: along the optical axis (perspective convention); range: distance along the ray (spherical).
enum class DepthMeasure { automatic, z, range };
// automatic: z for perspective cameras, range for equirectangular ones.
DepthMeasure resolve_depth_measure(DepthMeasure kind, const Camera& camera);

// What the colour image shows. automatic: the texture when one is given and the mesh has uvs, else
// vertex colours when the mesh has them, else white.
enum class Shading { none, automatic, texture, vertex_colors, white };

struct RenderOptions {
  bool cull_back_faces = false;  // back face: seen from behind (faces are counter-clockwise from outside)
  DepthMeasure depth_kind = DepthMeasure::automatic;
  double near = 0;  // hits at a range <= near are ignored
  Shading shading = Shading::none;
  const Texture* texture = nullptr;  // not owned; used by Shading::texture / automatic
  // Lambert factor ambient + (1 - ambient) * max(0, n . l) with two-sided normals (vertex normals when
  // the mesh has them, else face normals); l is towards the light, a headlight when not given.
  bool lambert = false;
  std::optional<Eigen::Vector3d> light_direction_world;
  float ambient = 0.1f;
  Eigen::Vector3f background = Eigen::Vector3f::Zero();  // colour where no triangle is hit
};

// Per-pixel results, row-major, width x height. These are the public per-pixel outputs refinement uses.
struct RenderBuffers {
  int width = 0, height = 0;
  std::vector<std::uint32_t> triangle;  // face index, kNoTriangle where no hit
  std::vector<float> b1, b2;  // barycentric weights of the face's vertices 1 and 2; b0 = 1 - b1 - b2
  cv::Mat depth;              // CV_32F, NaN where no hit
  DepthMeasure depth_kind = DepthMeasure::z;  // what depth holds (never automatic)
  cv::Mat color;  // CV_32FC3 linear (texture channel order; vertex colours as BGR)

  std::size_t index(int x, int y) const { return std::size_t(y) * width + x; }
  std::uint32_t triangle_at(int x, int y) const { return triangle[index(x, y)]; }
  Eigen::Vector3f barycentric_at(int x, int y) const {
    std::size_t i = index(x, y);
    return {1.0f - b1[i] - b2[i], b1[i], b2[i]};
  }
};

// The world-space surface point seen at pixel (x, y) (from triangle id and barycentrics); NaN if none.
Eigen::Vector3d surface_point(const Mesh& mesh, const RenderBuffers& buffers, int x, int y);

// Renders repeatedly without reallocating: keep one Renderer (and the camera's RayTable) per view.
class Renderer {
 public:
  // `rays` must have been built for `camera` (RayTable::matches); the pose comes from `camera`.
  void render(const Mesh& mesh, const Camera& camera, const RayTable& rays, const RenderOptions& options,
              RenderBuffers& out);

  // What render() rasterizes from, exposed so that an accelerated rasterizer (pg/gpu) runs the same
  // per-pixel tests on the same data and agrees with render() bit for bit. prepare() validates the
  // inputs and computes the triangle setups and tile bins; render() is prepare(), the per-pixel loop of
  // rasterize_tiles() and shade().
  struct TriangleSetup {
    float edge[3][3];      // edge-plane normals, oriented so a ray d is inside iff all dot(d, edge[i]) > 0
    float depth_plane[3];  // plane normal / (plane offset): range along unit ray d = 1 / dot(d, depth_plane)
    std::uint8_t tie = 0;  // bit i: rays exactly on edge plane i belong to this triangle
  };
  // Tiles are kTileSize x kTileSize pixels; tile (tx, ty) is number ty * tiles_x() + tx.
  static constexpr int kTileSize = 32;
  void prepare(const Mesh& mesh, const Camera& camera, const RayTable& rays, const RenderOptions& options);
  // Per face (valid after prepare): its setup and its pixel boxes (box_counts()[t] of them, 0 for faces
  // that are culled, degenerate or outside the image; their setups are then meaningless).
  const std::vector<TriangleSetup>& triangle_setups() const { return setups_; }
  const std::vector<std::array<PixelBox, 2>>& pixel_boxes() const { return boxes_; }
  const std::vector<std::uint8_t>& box_counts() const { return box_counts_; }
  int tiles_x() const { return tiles_x_; }
  int tiles_y() const { return tiles_y_; }
  // The faces of tile k are tile_triangles()[tile_offsets()[k] .. tile_offsets()[k + 1]), in index order
  // (the first of equal depths wins).
  const std::vector<std::uint32_t>& tile_offsets() const { return tile_offsets_; }
  const std::vector<std::uint32_t>& tile_triangles() const { return tile_triangles_; }
  // Fills out.color from out.triangle and the barycentrics (after prepare() for the same view; does
  // nothing but release the colour for Shading::none).
  void shade(const Mesh& mesh, const Camera& camera, const RayTable& rays, const RenderOptions& options,
             RenderBuffers& out) const;

 private:
  void setup_triangles(const Mesh& mesh, const RayTable& rays, const RenderOptions& options);
  void bin_triangles(const RayTable& rays);
  void rasterize_tiles(const RayTable& rays, const RenderOptions& options, DepthMeasure kind,
                       RenderBuffers& out);
  void shade_colors(const Mesh& mesh, const Camera& camera, const RayTable& rays,
                    const RenderOptions& options, RenderBuffers& out) const;

  std::vector<Eigen::Vector3d> cam_positions_;
  std::vector<TriangleSetup> setups_;
  std::vector<std::array<PixelBox, 2>> boxes_;
  std::vector<std::uint8_t> box_counts_;
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<std::uint32_t> tile_offsets_;  // tiles + 1 entries into tile_triangles_
  std::vector<std::uint32_t> tile_triangles_;
};

// One-off render (builds the camera's RayTable; prefer Renderer + a cached RayTable for repeated views).
RenderBuffers render(const Mesh& mesh, const Camera& camera, const RenderOptions& options = {});

}  // namespace pg
