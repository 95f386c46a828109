#pragma once
// Peak memory of a refinement, estimated from the mesh and the cameras before any image is decoded,
// so that pg-refine can refuse a job over its --max-memory budget (exit code 5) instead of being
// killed. The counts are what refine_mesh, its per-view state and the rasterizer hold at once; keep
// them in step with refine.cpp, pair_estimate.cpp and render/rasterizer.h.
#include <cstdint>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/mesh/mesh.h"
#include "pg/refine/refine.h"

namespace pg {

// refine_mesh's per-vertex arrays: vertex-graph offsets 4, motion factor 4, fixed flag 1, total
// displacement 12, DisplacementSums (weight 8, normal matrix 72, rhs 24), observed 12, confidence 4,
// the smoothing's two buffers 24, the normal-only shape (positions and normals) 24, the result's
// "displacement" property 4.
inline constexpr std::uint64_t refine_bytes_per_vertex =
    4 + 4 + 1 + 12 + (8 + 72 + 24) + 12 + 4 + 24 + 24 + 4;
// The vertex graph's neighbour lists: 2 entries per edge, at most 6 per face (open meshes), 4 bytes.
inline constexpr std::uint64_t refine_bytes_per_face = 6 * 4;
// Each view's Renderer keeps the vertices in camera coordinates (3 doubles) and per face its edge and
// depth planes (52 bytes), two pixel boxes (32), their count (1) and at least one tile entry (4).
inline constexpr std::uint64_t renderer_bytes_per_vertex = 3 * 8;
inline constexpr std::uint64_t renderer_bytes_per_face = 52 + 32 + 1 + 4;
// Each view's state at the working resolution: the grey photograph (4), the ray table's directions
// (3 floats) and its cube-face grid of about one 16-byte pixel box per ray, and the render buffers
// (triangle id, two barycentrics, depth: 4 each).
inline constexpr std::uint64_t refine_view_bytes_per_pixel = 4 + 3 * 4 + 16 + 4 * 4;
// One directed pair at a time, at the working resolution, beside its flow: the synthetic view (grey
// 4, valid 1), the first pair's two error images (8), and estimate_displacements' border distance,
// pixel weights and offsets (12).
inline constexpr std::uint64_t refine_pair_bytes_per_pixel = 5 + 8 + 12;

// Bytes of a mesh's own arrays (positions, faces, normals, colours, uvs, vertex properties).
std::uint64_t mesh_bytes(const Mesh& mesh);

// Bytes refine_mesh needs on `mesh` with `views` (the cameras of the views in use, at full size),
// plus the decoded photographs its caller holds (image_bytes_per_pixel each, full size):
//   2 * mesh_bytes(mesh)                                        the input and the refined mesh
//   + V * refine_bytes_per_vertex + F * refine_bytes_per_face
//   + per view: V * renderer_bytes_per_vertex + F * renderer_bytes_per_face
//               + full pixels * image_bytes_per_pixel + working pixels * refine_view_bytes_per_pixel
//   + the largest view's pair: working pixels * refine_pair_bytes_per_pixel
//                              + flow_memory_bytes(working size, 1 channel, options.flow)
std::uint64_t refine_memory_bytes(const Mesh& mesh, const std::vector<Camera>& views,
                                  std::uint64_t image_bytes_per_pixel, const RefineOptions& options);

}  // namespace pg
