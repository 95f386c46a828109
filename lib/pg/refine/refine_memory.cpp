#include "pg/refine/refine_memory.h"

#include <algorithm>

#include "pg/flow/flow_memory.h"

namespace pg {

std::uint64_t mesh_bytes(const Mesh& mesh) {
  std::uint64_t bytes =
      mesh.positions.size() * sizeof(mesh.positions[0]) + mesh.faces.size() * sizeof(mesh.faces[0]) +
      mesh.normals.size() * sizeof(Eigen::Vector3f) +
      mesh.colors.size() * sizeof(std::array<std::uint8_t, 3>) + mesh.uvs.size() * sizeof(Eigen::Vector2f);
  for (const auto& [name, values] : mesh.vertex_properties) bytes += values.size() * sizeof(float);
  return bytes;
}

std::uint64_t refine_memory_bytes(const Mesh& mesh, const std::vector<Camera>& views,
                                  std::uint64_t image_bytes_per_pixel, const RefineOptions& options) {
  const std::uint64_t vertices = mesh.vertex_count(), faces = mesh.faces.size();
  std::uint64_t bytes =
      2 * mesh_bytes(mesh) + vertices * refine_bytes_per_vertex + faces * refine_bytes_per_face;
  std::uint64_t largest_pair = 0;
  for (const Camera& camera : views) {
    const Camera working = resized_camera(camera, options.scale);
    const cv::Size size(working.width, working.height);
    const std::uint64_t full = std::uint64_t(camera.width) * std::uint64_t(camera.height);
    const std::uint64_t pixels = std::uint64_t(size.area());
    bytes += vertices * renderer_bytes_per_vertex + faces * renderer_bytes_per_face +
             full * image_bytes_per_pixel + pixels * refine_view_bytes_per_pixel;
    // The flow runs on grey images: one channel.
    const std::uint64_t pair =
        pixels * refine_pair_bytes_per_pixel +
        flow_memory_bytes(size, 1, options.flow, options.flow_mode == RefineFlow::epipolar);
    largest_pair = std::max(largest_pair, pair);
  }
  return bytes + largest_pair;
}

}  // namespace pg
