#pragma once
// Built-in synthetic scenes with exact ground truth (cameras, mesh, depth).
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pg/camera/cameras_io.h"
#include "pg/mesh/mesh.h"
#include "pg/synth/solid_texture.h"

namespace pg::synth {

enum class Material : int { ground = 0, wall = 1, box = 2, rock = 3, cloth = 4, plaster = 5, board = 10 };

struct Scene {
  std::string name;
  Mesh mesh;                       // the ground-truth surface
  std::vector<int> face_material;  // one per face
  // Where each vertex samples the solid texture (the rest shape for deformed meshes, board-local
  // coordinates for the checkerboard). Same size as mesh.positions.
  std::vector<Eigen::Vector3f> texture_points;
  CameraSet cameras;
  SolidTexture texture{1, 1.0f};
  Eigen::Vector3f light_direction = Eigen::Vector3f(0.3f, -0.4f, 0.86f).normalized();  // towards the light
  bool lit = true;  // Lambert shading; off for the checkerboard
  Eigen::Vector3f background = Eigen::Vector3f::Zero();
  std::optional<Mesh> initial_mesh;  // deform scene: the mesh refinement starts from
  struct Board {
    int inner_x = 9, inner_y = 6;  // inner corners
    double square = 0.025;         // metres
  };
  std::optional<Board> board;                        // checkerboard scene
  nlohmann::json extras = nlohmann::json::object();  // scene facts for the manifest (board geometry...)

  // Linear RGB albedo of the surface point with barycentrics (b0, b1, b2) on `face`.
  Eigen::Vector3f albedo(std::uint32_t face, float b1, float b2) const;
};

struct SceneOptions {
  std::uint32_t seed = 1;
  int width = 640, height = 480;  // pinhole scenes; the room uses 2:1 panoramas of `height` rows * 2
  int views = 0;                  // 0: the scene's default
  CameraModel lens = CameraModel::pinhole;  // checkerboard: pinhole (k1 k2 p1 p2 k3) or fisheye (k1..k4)
};

Scene make_set_scene(const SceneOptions& options);           // orbit of 16 cameras around a set
Scene make_checkerboard_scene(const SceneOptions& options);  // 15 views of a 9x6 board, distorted lens
Scene make_room_scene(const SceneOptions& options);          // two panoramas 27 cm apart
Scene make_deform_scene(const SceneOptions& options);        // rock with a known low-frequency deformation
Scene make_scene(const std::string& name, const SceneOptions& options);  // throws UsageError
std::vector<std::string> scene_names();

}  // namespace pg::synth
