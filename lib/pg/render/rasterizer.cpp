#include "pg/render/rasterizer.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"

namespace pg {
namespace {

constexpr int kTile = Renderer::kTileSize;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Tie rule for rays exactly on an edge plane: the plane normal's first non-zero component decides.
// The neighbouring triangle holds exactly the negated normal, so exactly one of the two claims the ray.
bool claims_ties(const float m[3]) {
  for (int c = 0; c < 3; ++c)
    if (m[c] != 0) return m[c] > 0;
  return false;
}

}  // namespace

DepthMeasure resolve_depth_measure(DepthMeasure kind, const Camera& camera) {
  if (kind != DepthMeasure::automatic) return kind;
  return camera.is_perspective() ? DepthMeasure::z : DepthMeasure::range;
}

Eigen::Vector3d surface_point(const Mesh& mesh, const RenderBuffers& buffers, int x, int y) {
  std::uint32_t t = buffers.triangle_at(x, y);
  if (t == kNoTriangle) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const auto& f = mesh.faces[t];
  std::size_t i = buffers.index(x, y);
  double w1 = buffers.b1[i], w2 = buffers.b2[i];
  return (1 - w1 - w2) * mesh.positions[f[0]].cast<double>() + w1 * mesh.positions[f[1]].cast<double>() +
         w2 * mesh.positions[f[2]].cast<double>();
}

void Renderer::prepare(const Mesh& mesh, const Camera& camera, const RayTable& rays,
                       const RenderOptions& options) {
  if (!rays.matches(camera))
    throw UsageError(str("render: the ray table was not built for camera \"", camera.id, "\""));
  std::size_t n = mesh.positions.size();
  for (const auto& f : mesh.faces)
    if (f[0] >= n || f[1] >= n || f[2] >= n) throw UsageError("render: a face indexes a missing vertex");

  const Eigen::Matrix3d rotation = camera.cam_from_world.rotation_matrix();
  const Eigen::Vector3d translation = camera.cam_from_world.translation;
  cam_positions_.resize(n);
  parallel_chunks(std::int64_t(n), 16384, [&](std::int64_t b, std::int64_t e) {
    for (std::int64_t i = b; i < e; ++i)
      cam_positions_[i] = rotation * mesh.positions[i].cast<double>() + translation;
  });
  setup_triangles(mesh, rays, options);
  bin_triangles(rays);
}

void Renderer::render(const Mesh& mesh, const Camera& camera, const RayTable& rays,
                      const RenderOptions& options, RenderBuffers& out) {
  prepare(mesh, camera, rays, options);
  DepthMeasure kind = resolve_depth_measure(options.depth_kind, camera);
  std::size_t pixels = std::size_t(rays.width()) * rays.height();
  out.width = rays.width();
  out.height = rays.height();
  out.depth_kind = kind;
  out.triangle.resize(pixels);
  out.b1.resize(pixels);
  out.b2.resize(pixels);
  out.depth.create(rays.height(), rays.width(), CV_32F);
  rasterize_tiles(rays, options, kind, out);
  shade(mesh, camera, rays, options, out);
}

void Renderer::shade(const Mesh& mesh, const Camera& camera, const RayTable& rays,
                     const RenderOptions& options, RenderBuffers& out) const {
  if (options.shading == Shading::none)
    out.color.release();
  else
    shade_colors(mesh, camera, rays, options, out);
}

void Renderer::setup_triangles(const Mesh& mesh, const RayTable& rays, const RenderOptions& options) {
  std::size_t count = mesh.faces.size();
  setups_.resize(count);
  boxes_.resize(count);
  box_counts_.resize(count);
  parallel_chunks(std::int64_t(count), 4096, [&](std::int64_t b, std::int64_t e) {
    for (std::int64_t t = b; t < e; ++t) {
      box_counts_[t] = 0;
      const auto& idx = mesh.faces[t];
      const Eigen::Vector3d v[3] = {cam_positions_[idx[0]], cam_positions_[idx[1]], cam_positions_[idx[2]]};
      Eigen::Vector3d normal = (v[1] - v[0]).cross(v[2] - v[0]);
      double det = normal.dot(v[0]);  // < 0: front face (its outside normal points at the camera)
      if (!std::isfinite(det) || det == 0) continue;
      if (options.cull_back_faces && det > 0) continue;
      double sign = det > 0 ? 1.0 : -1.0;
      TriangleSetup& s = setups_[t];
      s.tie = 0;
      for (int i = 0; i < 3; ++i) {
        // Plane through the camera centre and the edge opposite vertex i, computed from the vertices in
        // index order so both triangles sharing the edge get bit-identical (negated) normals.
        std::uint32_t j = idx[(i + 1) % 3], k = idx[(i + 2) % 3];
        Eigen::Vector3d plane =
            j < k ? cam_positions_[j].cross(cam_positions_[k]) : -cam_positions_[k].cross(cam_positions_[j]);
        for (int c = 0; c < 3; ++c) s.edge[i][c] = float(sign * plane[c]);
        if (claims_ties(s.edge[i])) s.tie |= std::uint8_t(1u << i);
      }
      for (int c = 0; c < 3; ++c) s.depth_plane[c] = float(normal[c] / det);
      box_counts_[t] = std::uint8_t(rays.pixel_boxes(v, 3, boxes_[t]));
    }
  });
}

void Renderer::bin_triangles(const RayTable& rays) {
  tiles_x_ = (rays.width() + kTile - 1) / kTile;
  tiles_y_ = (rays.height() + kTile - 1) / kTile;
  tile_offsets_.assign(std::size_t(tiles_x_) * tiles_y_ + 1, 0);
  auto for_each_tile = [&](std::size_t t, auto&& visit) {
    for (int b = 0; b < box_counts_[t]; ++b) {
      const PixelBox& box = boxes_[t][b];
      for (int ty = box.y0 / kTile; ty <= box.y1 / kTile; ++ty)
        for (int tx = box.x0 / kTile; tx <= box.x1 / kTile; ++tx) visit(std::size_t(ty) * tiles_x_ + tx);
    }
  };
  std::size_t count = setups_.size();
  for (std::size_t t = 0; t < count; ++t)
    for_each_tile(t, [&](std::size_t tile) { ++tile_offsets_[tile + 1]; });
  for (std::size_t i = 1; i < tile_offsets_.size(); ++i) tile_offsets_[i] += tile_offsets_[i - 1];
  tile_triangles_.resize(tile_offsets_.back());
  std::vector<std::uint32_t> cursor(tile_offsets_.begin(), tile_offsets_.end() - 1);
  // Triangles enter each tile in index order: depth ties resolve to the lowest index, deterministically.
  for (std::size_t t = 0; t < count; ++t)
    for_each_tile(t, [&](std::size_t tile) { tile_triangles_[cursor[tile]++] = std::uint32_t(t); });
}

void Renderer::rasterize_tiles(const RayTable& rays, const RenderOptions& options, DepthMeasure kind,
                               RenderBuffers& out) {
  const int width = rays.width(), height = rays.height();
  const float* dx = rays.dx();
  const float* dy = rays.dy();
  const float* dz = rays.dz();
  const float near = float(options.near);
  parallel_chunks(std::int64_t(tiles_x_) * tiles_y_, 1, [&](std::int64_t tile_begin, std::int64_t tile_end) {
    for (std::int64_t tile = tile_begin; tile < tile_end; ++tile) {
      const int tx0 = int(tile % tiles_x_) * kTile, ty0 = int(tile / tiles_x_) * kTile;
      const int tx1 = std::min(width, tx0 + kTile) - 1, ty1 = std::min(height, ty0 + kTile) - 1;
      // The tile's own depth buffer (range along the ray) and results, indexed [y - ty0][x - tx0].
      std::array<float, kTile * kTile> best, w1, w2;
      std::array<std::uint32_t, kTile * kTile> ids;
      best.fill(kInf);
      ids.fill(kNoTriangle);
      w1.fill(0);
      w2.fill(0);
      for (std::uint32_t k = tile_offsets_[tile]; k < tile_offsets_[tile + 1]; ++k) {
        const std::uint32_t tri = tile_triangles_[k];
        const TriangleSetup& s = setups_[tri];
        const float a0 = s.edge[0][0], a1 = s.edge[0][1], a2 = s.edge[0][2];
        const float c0 = s.edge[1][0], c1 = s.edge[1][1], c2 = s.edge[1][2];
        const float g0 = s.edge[2][0], g1 = s.edge[2][1], g2 = s.edge[2][2];
        const float p0 = s.depth_plane[0], p1 = s.depth_plane[1], p2 = s.depth_plane[2];
        const bool tie0 = s.tie & 1, tie1 = s.tie & 2, tie2 = s.tie & 4;
        for (int b = 0; b < box_counts_[tri]; ++b) {
          const PixelBox& box = boxes_[tri][b];
          const int x0 = std::max(box.x0, tx0), x1 = std::min(box.x1, tx1);
          const int y0 = std::max(box.y0, ty0), y1 = std::min(box.y1, ty1);
          for (int y = y0; y <= y1; ++y) {
            const std::size_t row = std::size_t(y) * width;
            const int local_row = (y - ty0) * kTile - tx0;
            for (int x = x0; x <= x1; ++x) {
              const float X = dx[row + x], Y = dy[row + x], Z = dz[row + x];
              const float e0 = X * a0 + Y * a1 + Z * a2;
              const float e1 = X * c0 + Y * c1 + Z * c2;
              const float e2 = X * g0 + Y * g1 + Z * g2;
              const bool inside = (e0 > 0 || (e0 == 0 && tie0)) && (e1 > 0 || (e1 == 0 && tie1)) &&
                                  (e2 > 0 || (e2 == 0 && tie2));
              if (!inside) continue;
              const float range = 1.0f / (X * p0 + Y * p1 + Z * p2);
              const int l = local_row + x;
              if (!(range > near && range < best[l])) continue;
              const float inv_sum = 1.0f / (e0 + e1 + e2);
              best[l] = range;
              ids[l] = tri;
              w1[l] = e1 * inv_sum;
              w2[l] = e2 * inv_sum;
            }
          }
        }
      }
      for (int y = ty0; y <= ty1; ++y) {
        float* depth = out.depth.ptr<float>(y);
        for (int x = tx0; x <= tx1; ++x) {
          const int l = (y - ty0) * kTile + (x - tx0);
          const std::size_t i = std::size_t(y) * width + x;
          out.triangle[i] = ids[l];
          out.b1[i] = w1[l];
          out.b2[i] = w2[l];
          if (ids[l] == kNoTriangle)
            depth[x] = std::numeric_limits<float>::quiet_NaN();
          else
            depth[x] = kind == DepthMeasure::z ? best[l] * dz[i] : best[l];
        }
      }
    }
  });
}

void Renderer::shade_colors(const Mesh& mesh, const Camera& camera, const RayTable& rays,
                            const RenderOptions& options, RenderBuffers& out) const {
  const std::size_t n = mesh.positions.size();
  const bool has_texture = options.texture && !options.texture->empty() && mesh.uvs.size() == n;
  const bool has_colors = mesh.colors.size() == n;
  Shading source = options.shading;
  if (source == Shading::automatic)
    source = has_texture ? Shading::texture : (has_colors ? Shading::vertex_colors : Shading::white);
  if (source == Shading::texture && !has_texture)
    throw UsageError("render: texture shading needs a texture and per-vertex uvs");
  if (source == Shading::vertex_colors && !has_colors)
    throw UsageError("render: vertex-colour shading needs per-vertex colours");

  std::array<float, 256> srgb_table;
  for (int i = 0; i < 256; ++i) srgb_table[i] = linear_from_srgb(i / 255.0f);
  const Eigen::Matrix3f rotation = camera.cam_from_world.rotation_matrix().cast<float>();
  std::optional<Eigen::Vector3f> light;
  if (options.light_direction_world)
    light = (rotation * options.light_direction_world->cast<float>()).normalized();
  const bool vertex_normals = mesh.normals.size() == n;
  const int width = out.width, height = out.height;
  const Texture* texture = options.texture;

  // Barycentrics of triangle `s` along ray i (also outside the triangle, for texture footprints).
  auto barycentric = [&](const TriangleSetup& s, std::size_t i, Eigen::Vector3f& w) {
    Eigen::Vector3f d(rays.dx()[i], rays.dy()[i], rays.dz()[i]);
    for (int k = 0; k < 3; ++k) w[k] = d.dot(Eigen::Vector3f(s.edge[k]));
    float sum = w.sum();
    if (!(sum > 0)) return false;
    w /= sum;
    return true;
  };
  auto uv_at = [&](const std::array<std::uint32_t, 3>& f, const Eigen::Vector3f& w) {
    return Eigen::Vector2f(w[0] * mesh.uvs[f[0]] + w[1] * mesh.uvs[f[1]] + w[2] * mesh.uvs[f[2]]);
  };

  out.color.create(height, width, CV_32FC3);
  parallel_chunks(height, 8, [&](std::int64_t y_begin, std::int64_t y_end) {
    for (int y = int(y_begin); y < int(y_end); ++y) {
      cv::Vec3f* row = out.color.ptr<cv::Vec3f>(y);
      for (int x = 0; x < width; ++x) {
        const std::size_t i = out.index(x, y);
        const std::uint32_t t = out.triangle[i];
        if (t == kNoTriangle) {
          row[x] = {options.background[0], options.background[1], options.background[2]};
          continue;
        }
        const auto& f = mesh.faces[t];
        const Eigen::Vector3f w = out.barycentric_at(x, y);
        Eigen::Vector3f c = Eigen::Vector3f::Ones();
        if (source == Shading::texture) {
          const Eigen::Vector2f uv = uv_at(f, w);
          // Footprint: the same triangle's uv along the neighbouring pixels' rays.
          const int xn = x + 1 < width ? x + 1 : (rays.wraps_columns() ? 0 : x - 1);
          const int yn = y + 1 < height ? y + 1 : y - 1;
          Eigen::Vector3f wx, wy;
          float lod = float(texture->level_count() - 1);
          if (xn >= 0 && yn >= 0 && barycentric(setups_[t], out.index(xn, y), wx) &&
              barycentric(setups_[t], out.index(x, yn), wy))
            lod = texture->lod(uv_at(f, wx) - uv, uv_at(f, wy) - uv);
          c = texture->sample(uv, lod);
        } else if (source == Shading::vertex_colors) {
          for (int k = 0; k < 3; ++k) {
            // Mesh colours are RGB; the image is BGR like every OpenCV image.
            c[2 - k] = w[0] * srgb_table[mesh.colors[f[0]][k]] + w[1] * srgb_table[mesh.colors[f[1]][k]] +
                       w[2] * srgb_table[mesh.colors[f[2]][k]];
          }
        }
        if (options.lambert) {
          Eigen::Vector3f normal;
          if (vertex_normals)
            normal = w[0] * mesh.normals[f[0]] + w[1] * mesh.normals[f[1]] + w[2] * mesh.normals[f[2]];
          else
            normal = (mesh.positions[f[1]] - mesh.positions[f[0]])
                         .cross(mesh.positions[f[2]] - mesh.positions[f[0]]);
          normal = (rotation * normal).normalized();
          const Eigen::Vector3f d(rays.dx()[i], rays.dy()[i], rays.dz()[i]);
          if (normal.dot(d) > 0) normal = -normal;  // two-sided: face the viewer
          const Eigen::Vector3f l = light ? *light : Eigen::Vector3f(-d);
          float lit = std::max(0.0f, normal.dot(l));
          if (!std::isfinite(lit)) lit = 0;
          c *= options.ambient + (1 - options.ambient) * lit;
        }
        row[x] = {c[0], c[1], c[2]};
      }
    }
  });
}

RenderBuffers render(const Mesh& mesh, const Camera& camera, const RenderOptions& options) {
  RayTable rays(camera);
  Renderer renderer;
  RenderBuffers out;
  renderer.render(mesh, camera, rays, options, out);
  return out;
}

}  // namespace pg
