#include "pg/synth/scenes.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "pg/core/error.h"
#include "pg/synth/shapes.h"

namespace pg::synth {
namespace {

Scene finish(std::string name, MeshBuilder&& builder, const SceneOptions& options, float texture_scale) {
  Scene scene;
  scene.name = std::move(name);
  scene.mesh = std::move(builder.mesh);
  scene.face_material = std::move(builder.face_material);
  scene.texture_points = scene.mesh.positions;
  scene.texture = SolidTexture(options.seed, texture_scale);
  return scene;
}

Camera pinhole(const std::string& id, int width, int height, double focal) {
  Camera c;
  c.id = id;
  c.image = "images/" + id + ".png";
  c.width = width;
  c.height = height;
  c.model = CameraModel::pinhole;
  c.intrinsics = {focal, focal, (width - 1) / 2.0, (height - 1) / 2.0};
  return c;
}

std::string view_id(int i) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "view_%03d", i);
  return buffer;
}

// Deterministic jitter in [-1, 1] per (seed, index, channel).
double jitter(std::uint32_t seed, int index, int channel) {
  return value_noise(Eigen::Vector3f(float(index) * 1.37f + 0.5f, float(channel) * 2.11f + 0.5f, 0.5f),
                     seed + 991);
}

}  // namespace

Eigen::Vector3f Scene::albedo(std::uint32_t face, float b1, float b2) const {
  const auto& f = mesh.faces[face];
  Eigen::Vector3f p =
      (1 - b1 - b2) * texture_points[f[0]] + b1 * texture_points[f[1]] + b2 * texture_points[f[2]];
  int material = face_material[face];
  if (material == int(Material::board)) {
    // Board-local metres: squares of extras.square_size, inner corners at multiples of it, a white
    // margin of one square around the checker area.
    double square = board->square;
    int cols = board->inner_x + 1, rows = board->inner_y + 1;
    double x = p.x() / square + 1.0, y = p.y() / square + 1.0;  // (0,0) = checker area's corner
    if (x < 0 || y < 0 || x >= cols || y >= rows) return Eigen::Vector3f(0.92f, 0.92f, 0.92f);
    bool dark = (int(std::floor(x)) + int(std::floor(y))) % 2 == 0;
    return dark ? Eigen::Vector3f(0.04f, 0.04f, 0.04f) : Eigen::Vector3f(0.92f, 0.92f, 0.92f);
  }
  return texture.albedo(p, material);
}

Scene make_set_scene(const SceneOptions& o) {
  MeshBuilder b;
  const std::uint32_t seed = o.seed;
  // Ground 8 m x 8 m with relief: a few broad bumps plus fine fractal roughness.
  b.add_grid(
      200, 200,
      [&](float u, float v) {
        float x = -4 + 8 * u, y = -4 + 8 * v;
        float z = 0.12f * std::sin(0.9f * x + 0.3f) * std::cos(0.7f * y) +
                  0.05f * fbm(Eigen::Vector3f(x * 0.8f, y * 0.8f, 0.5f), 3, seed + 3);
        return Eigen::Vector3f(x, y, z);
      },
      int(Material::ground));
  // A low L-shaped wall behind the objects.
  b.add_box({0.2f, 2.3f, 0.45f}, {4.0f, 0.25f, 1.1f}, 0.0f, 6, int(Material::wall));
  b.add_box({-2.2f, 1.2f, 0.45f}, {0.25f, 2.2f, 1.1f}, 0.0f, 6, int(Material::wall));
  // Boxes of several sizes and orientations.
  b.add_box({1.3f, -0.6f, 0.35f}, {0.7f, 0.5f, 0.7f}, 0.4f, 4, int(Material::box));
  b.add_box({-1.0f, -1.3f, 0.25f}, {0.5f, 0.5f, 0.5f}, -0.7f, 4, int(Material::box));
  b.add_box({1.6f, 1.2f, 0.6f}, {0.6f, 0.6f, 1.2f}, 0.15f, 4, int(Material::cloth));
  // A rock: a displaced icosphere.
  b.add_sphere(
      {-0.2f, 0.3f, 0.45f}, 5,
      [&](const Eigen::Vector3f& d) { return 0.6f * (1.0f + 0.18f * fbm(d * 1.6f, 4, seed + 5)); },
      int(Material::rock));
  Scene scene = finish("set", std::move(b), o, 1.5f);

  int views = o.views > 0 ? o.views : 16;
  double focal = 0.85 * o.width;
  for (int i = 0; i < views; ++i) {
    double angle = 2 * std::numbers::pi * i / views + 0.02 * jitter(seed, i, 0);
    double radius = 5.5 + 0.2 * jitter(seed, i, 1);
    Eigen::Vector3d centre(radius * std::cos(angle), radius * std::sin(angle),
                           2.4 + 0.15 * jitter(seed, i, 2));
    Camera c = pinhole(view_id(i), o.width, o.height, focal);
    c.cam_from_world = Rigid3::look_at(centre, Eigen::Vector3d(0, 0, 0.3));
    scene.cameras.cameras.push_back(c);
  }
  scene.extras["orbit"] = {{"views", views}, {"radius_m", 5.5}, {"height_m", 2.4}, {"closes_ring", true}};
  return scene;
}

namespace {

// Where a calibration view puts the board: its centre towards (u, v) (fractions of the half-frame,
// pushed as far out as the board fits), tilted about the board's x and y axes, rolled about the optical
// axis, its inner corners spanning about `span` of the image width.
struct BoardPlacement {
  double u, v, tilt_x, tilt_y, roll, span;
};

// Informative views first, so a few views (--views) still cover the frame: a tilted centre view, the
// four corners, the four edges, then the corners again at other tilts and sizes, then close views.
// Every board is rolled a little: edges aligned with the pixel grid would all fall at the same phase of
// the supersampling grid, which moves them in steps of 1 / supersample px.
std::vector<BoardPlacement> calibration_placements() {
  return {{0, 0, 0.6, 0, 0.15, 0.6},       {-1, -1, 0.5, -0.5, 0.12, 0.45}, {1, -1, -0.5, -0.5, -0.12, 0.45},
          {1, 1, -0.5, 0.5, 0.12, 0.45},   {-1, 1, 0.5, 0.5, -0.12, 0.45},  {0, -1, -0.7, 0, 0.15, 0.55},
          {1, 0, 0, 0.7, -0.15, 0.5},      {0, 1, 0.7, 0, 0.15, 0.55},      {-1, 0, 0, -0.7, -0.15, 0.5},
          {-1, -1, -0.3, 0.6, -0.2, 0.35}, {1, -1, 0.6, 0.3, 0.2, 0.35},    {1, 1, 0.3, -0.6, -0.2, 0.35},
          {-1, 1, -0.6, -0.3, 0.2, 0.35},  {0, 0, 0, 0.75, 0.15, 0.8},      {0, 0, -0.3, 0.3, -0.25, 0.95}};
}

// cam_from_board for one placement: the board (with its white margin) inside the frame by a few
// pixels, its centre as far towards the placement's target as that allows, moved further away when it
// does not fit at all. Deterministic: bisection with a fixed number of steps.
Rigid3 place_board(const Camera& lens, int inner_x, int inner_y, double square, const BoardPlacement& p) {
  const Eigen::Vector2d image_centre((lens.width - 1) / 2.0, (lens.height - 1) / 2.0);
  const Eigen::Vector2d half(lens.width / 2.0, lens.height / 2.0);
  const auto ray_to = [&](double reach) {
    return lens.unproject(image_centre + reach * Eigen::Vector2d(p.u * half.x(), p.v * half.y()));
  };
  // Tilt relative to the line of sight: off-axis views (a fisheye's frame edge) are oblique already, so
  // the tilt is eased until the board is seen at most 55 degrees from face-on (detectors fail beyond).
  Eigen::Matrix3d rotation;
  for (double ease = 1;; ease *= 0.8) {
    rotation = (Eigen::AngleAxisd(p.roll, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(ease * p.tilt_x, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(ease * p.tilt_y, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
    if (rotation.col(2).dot(ray_to(1)) >= std::cos(55 * std::numbers::pi / 180) || ease < 0.05) break;
  }
  // The checker area plus half a square of its white margin (the detectors need that much quiet zone),
  // sampled along its edges (distortion bends them).
  std::vector<Eigen::Vector3d> outline;
  const double x0 = -1.5 * square, y0 = -1.5 * square, x1 = (inner_x + 0.5) * square,
               y1 = (inner_y + 0.5) * square;
  for (int k = 0; k <= 8; ++k) {
    const double t = k / 8.0;
    outline.emplace_back(x0 + t * (x1 - x0), y0, 0);
    outline.emplace_back(x0 + t * (x1 - x0), y1, 0);
    outline.emplace_back(x0, y0 + t * (y1 - y0), 0);
    outline.emplace_back(x1, y0 + t * (y1 - y0), 0);
  }
  const Eigen::Vector3d centre((inner_x - 1) * square / 2, (inner_y - 1) * square / 2, 0);
  const auto placed = [&](double distance, double reach) {
    const Eigen::Vector3d ray = ray_to(reach);
    Rigid3 pose;
    pose.rotation = Eigen::Quaterniond(rotation);
    pose.translation = distance / ray.z() * ray - rotation * centre;
    return pose;
  };
  const auto fits = [&](const Rigid3& pose) {
    Camera c = lens;
    c.cam_from_world = pose;
    for (const Eigen::Vector3d& q : outline) {
      Eigen::Vector2d px;
      if (!c.project_world(q, px) || !c.in_image(px, 3)) return false;
    }
    return true;
  };
  double distance = lens.intrinsics.fx * (inner_x - 1) * square / (p.span * lens.width);
  for (int k = 0; k < 100 && !fits(placed(distance, 0)); ++k) distance *= 1.1;
  double inside = 0, outside = 1;
  if (fits(placed(distance, 1))) return placed(distance, 1);
  for (int step = 0; step < 20; ++step) {
    const double mid = 0.5 * (inside + outside);
    (fits(placed(distance, mid)) ? inside : outside) = mid;
  }
  return placed(distance, inside);
}

}  // namespace

Scene make_checkerboard_scene(const SceneOptions& o) {
  const int inner_x = 9, inner_y = 6;
  const double square = 0.025;
  MeshBuilder b;
  // The board in its own frame: x across, y down the board, z into the board (so the front faces -z,
  // towards cameras placed at negative z). Checker area plus a one-square white margin.
  float w = float((inner_x + 3) * square), h = float((inner_y + 3) * square);
  float x0 = float(-2 * square), y0 = float(-2 * square);
  b.add_grid(
      24, 18, [&](float u, float v) { return Eigen::Vector3f(x0 + w * u, y0 + h * v, 0); },
      int(Material::board));
  // add_grid's outside is du x dv = +z; the board must face -z: flip its faces.
  for (auto& f : b.mesh.faces) std::swap(f[1], f[2]);
  // A textured backdrop 5 cm behind the board.
  b.add_grid(
      8, 8, [&](float u, float v) { return Eigen::Vector3f(-0.6f + 1.4f * v, -0.5f + 1.2f * u, 0.05f); },
      int(Material::cloth));
  Scene scene = finish("checkerboard", std::move(b), o, 0.2f);
  scene.lit = false;
  scene.background = Eigen::Vector3f(0.3f, 0.3f, 0.3f);

  Camera lens = pinhole("", o.width, o.height, 0.84 * o.width);
  lens.intrinsics.cx += 4.5;
  lens.intrinsics.cy -= 3.0;
  if (o.lens == CameraModel::fisheye) {
    lens.model = CameraModel::fisheye;
    lens.intrinsics.fx = lens.intrinsics.fy = 0.6 * o.width;
    lens.distortion.k1 = 0.05;
    lens.distortion.k2 = -0.02;
    lens.distortion.k3 = 0.004;
    lens.distortion.k4 = -0.001;
  } else {
    lens.distortion.k1 = -0.28;
    lens.distortion.k2 = 0.09;
    lens.distortion.p1 = 0.0008;
    lens.distortion.p2 = -0.0005;
    lens.distortion.k3 = -0.012;
  }

  // A calibration set pins the distortion and the principal point only where corners are seen: the
  // boards fill the frame's corners and edges, strongly tilted, as a careful photographer would shoot.
  const int views = o.views > 0 ? o.views : 15;
  const std::vector<BoardPlacement> placements = calibration_placements();
  for (int i = 0; i < views; ++i) {
    BoardPlacement p = placements[std::size_t(i) % placements.size()];
    const int round = i / int(placements.size());  // more views than placements: vary roll and tilt
    p.roll += 0.3 * round + 0.04 * jitter(o.seed, i, 0);
    p.tilt_x += 0.05 * jitter(o.seed, i, 1) - 0.1 * round;
    p.tilt_y += 0.05 * jitter(o.seed, i, 2);
    Camera c = lens;
    c.id = view_id(i);
    c.image = "images/" + c.id + ".png";
    c.cam_from_world = place_board(c, inner_x, inner_y, square, p);  // the world is the board's frame
    scene.cameras.cameras.push_back(c);
  }
  scene.board = Scene::Board{inner_x, inner_y, square};
  scene.extras["inner_corners"] = {inner_x, inner_y};
  scene.extras["square_size"] = square;
  scene.extras["board_frame"] =
      "x across, y down the board, z into the board; inner corner (i, j) at (i, j, 0) * square_size";
  return scene;
}

Scene make_room_scene(const SceneOptions& o) {
  MeshBuilder b;
  // An inward-facing room 6 m x 5 m x 3 m, walls subdivided so no triangle spans a large solid angle.
  b.add_box({0, 0, 1.5f}, {6.0f, 5.0f, 3.0f}, 0.0f, 16, int(Material::plaster), true);
  b.add_box({1.6f, 1.2f, 0.4f}, {1.2f, 0.8f, 0.8f}, 0.3f, 4, int(Material::box));
  b.add_box({-1.8f, -1.4f, 0.5f}, {0.8f, 0.8f, 1.0f}, -0.4f, 4, int(Material::cloth));
  b.add_box({-2.6f, 1.5f, 1.0f}, {0.4f, 1.6f, 2.0f}, 0.0f, 4, int(Material::wall));
  b.add_sphere(
      {1.0f, -1.3f, 0.45f}, 4,
      [&](const Eigen::Vector3f& d) { return 0.45f * (1.0f + 0.15f * fbm(d * 1.5f, 3, o.seed + 5)); },
      int(Material::rock));
  Scene scene = finish("room", std::move(b), o, 0.8f);
  scene.light_direction = Eigen::Vector3f(0.2f, 0.1f, 1.0f).normalized();

  const double offset = 0.27;
  Eigen::Vector3d lower(0.25, -0.15, 1.35);
  for (int i = 0; i < 2; ++i) {
    Camera c;
    c.id = i == 0 ? "pano_lower" : "pano_upper";
    c.image = "images/" + c.id + ".png";
    c.model = CameraModel::equirectangular;
    c.height = o.height;
    c.width = 2 * o.height;
    Eigen::Vector3d centre = lower + Eigen::Vector3d(0, 0, i * offset);
    c.cam_from_world = Rigid3::look_at(centre, centre + Eigen::Vector3d::UnitX());
    c.rig = "panorama_pair";
    scene.cameras.cameras.push_back(c);
  }
  Rig rig;
  rig.id = "panorama_pair";
  rig.camera_ids = {"pano_lower", "pano_upper"};
  // The upper centre in the lower camera's frame (camera y is down, so up is -y).
  rig.offset = scene.cameras.cameras[0].cam_from_world.rotation * Eigen::Vector3d(0, 0, offset);
  scene.cameras.rigs.push_back(rig);
  scene.extras["baseline_m"] = offset;
  return scene;
}

Scene make_deform_scene(const SceneOptions& o) {
  MeshBuilder b;
  const std::uint32_t seed = o.seed;
  auto rest_radius = [&](const Eigen::Vector3f& d) {
    return 0.5f * (1.0f + 0.2f * fbm(d * 1.8f, 4, seed + 5));
  };
  b.add_sphere({0, 0, 0.5f}, 5, rest_radius, int(Material::rock));
  Scene scene = finish("deform", std::move(b), o, 0.6f);
  // The rest shape is what the user modelled; the truth adds a smooth bulge along the normal.
  Mesh initial = scene.mesh;
  initial.compute_vertex_normals();
  const float amplitude = 0.04f;
  for (std::size_t i = 0; i < scene.mesh.positions.size(); ++i) {
    Eigen::Vector3f d = (initial.positions[i] - Eigen::Vector3f(0, 0, 0.5f)).normalized();
    // The camera ring looks down on the rock, so its underside is never seen: like a set piece resting
    // on the ground, it cannot be corrected from the photographs, and the deformation fades out there.
    float t = std::clamp((d.z() + 0.1f) / 0.4f, 0.0f, 1.0f);
    float seen = t * t * (3 - 2 * t);
    float bulge = amplitude * seen * (std::sin(2.0f * d.x() + 0.4f) * std::cos(1.5f * d.y()) + 0.5f * d.z());
    scene.mesh.positions[i] = initial.positions[i] + bulge * initial.normals[i];
  }
  initial.normals.clear();
  scene.texture_points = initial.positions;  // the paint moves with the surface
  scene.initial_mesh = std::move(initial);

  int views = o.views > 0 ? o.views : 12;
  double focal = 0.9 * o.width;
  for (int i = 0; i < views; ++i) {
    double angle = 2 * std::numbers::pi * i / views;
    double elevation = 0.35 + 0.25 * std::sin(3.0 * angle);
    Eigen::Vector3d centre(2.4 * std::cos(angle) * std::cos(elevation),
                           2.4 * std::sin(angle) * std::cos(elevation), 0.5 + 2.4 * std::sin(elevation));
    Camera c = pinhole(view_id(i), o.width, o.height, focal);
    c.cam_from_world = Rigid3::look_at(centre, Eigen::Vector3d(0, 0, 0.5));
    scene.cameras.cameras.push_back(c);
  }
  scene.extras["deformation"] = {{"amplitude_m", amplitude},
                                 {"direction", "along the rest-shape normals"},
                                 {"support", "fades out below the rock's equator, which no camera sees"}};
  return scene;
}

std::vector<std::string> scene_names() {
  return {"set", "checkerboard", "room", "deform"};
}

Scene make_scene(const std::string& name, const SceneOptions& options) {
  if (name == "set") return make_set_scene(options);
  if (name == "checkerboard") return make_checkerboard_scene(options);
  if (name == "room") return make_room_scene(options);
  if (name == "deform") return make_deform_scene(options);
  throw UsageError("unknown scene '" + name + "' (use set, checkerboard, room or deform)");
}

}  // namespace pg::synth
