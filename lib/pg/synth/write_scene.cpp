#include "pg/synth/write_scene.h"

#include <tbb/parallel_for.h>

#include <cmath>

#include "pg/camera/cameras_io.h"
#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"
#include "pg/core/progress.h"
#include "pg/core/run_report.h"
#include "pg/image/depth_exr.h"
#include "pg/image/image_io.h"
#include "pg/mesh/mesh_io.h"
#include "pg/render/rasterizer.h"

namespace fs = std::filesystem;

namespace pg::synth {
namespace {

std::vector<Eigen::Vector3f> face_normals(const Mesh& mesh) {
  std::vector<Eigen::Vector3f> normals(mesh.faces.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    normals[f] = (mesh.positions[t[1]] - mesh.positions[t[0]])
                     .cross(mesh.positions[t[2]] - mesh.positions[t[0]])
                     .normalized();
  }
  return normals;
}

// Truth mesh with per-vertex colours (albedo at the vertex) and the material as a named property.
Mesh truth_mesh_for_files(const Scene& scene) {
  Mesh mesh = scene.mesh;
  mesh.colors.assign(mesh.positions.size(), {0, 0, 0});
  std::vector<float> material(mesh.positions.size(), 0.0f);
  for (std::uint32_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      std::uint32_t v = mesh.faces[f][k];
      Eigen::Vector3f a = scene.albedo(f, k == 1 ? 1.0f : 0.0f, k == 2 ? 1.0f : 0.0f);
      for (int c = 0; c < 3; ++c)
        mesh.colors[v][c] = std::uint8_t(std::lround(255.0f * std::pow(a[c], 1 / 2.2f)));
      material[v] = float(scene.face_material[f]);
    }
  mesh.vertex_properties["material"] = std::move(material);
  mesh.provenance = Provenance::current();
  return mesh;
}

void record(const fs::path& path) {
  RunReport::global().add_output(path);
}

}  // namespace

ViewRenderer::ViewRenderer(const Scene& scene, int supersample)
    : scene_(scene), supersample_(supersample), face_normals_(face_normals(scene.mesh)) {}

RenderedView ViewRenderer::render(const Camera& camera) {
  Camera fine = resized_camera(camera, supersample_);
  if (!fine_rays_.matches(fine)) fine_rays_ = RayTable(fine);
  renderer_.render(scene_.mesh, fine, fine_rays_, RenderOptions{}, fine_buffers_);
  const RenderBuffers& buffers = fine_buffers_;
  Eigen::Vector3d centre = camera.cam_from_world.centre();
  const Eigen::Vector3f light = scene_.light_direction.normalized();
  const int s = supersample_;

  RenderedView view;
  view.color.create(camera.height, camera.width, CV_32FC3);
  const float inv_samples = 1.0f / float(s * s);
  tbb::parallel_for(0, camera.height, [&](int y) {
    auto* row = view.color.ptr<cv::Vec3f>(y);
    for (int x = 0; x < camera.width; ++x) {
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int sy = 0; sy < s; ++sy)
        for (int sx = 0; sx < s; ++sx) {
          std::size_t i = buffers.index(x * s + sx, y * s + sy);
          std::uint32_t face = buffers.triangle[i];
          if (face == kNoTriangle) {
            sum += scene_.background;
            continue;
          }
          Eigen::Vector3f colour = scene_.albedo(face, buffers.b1[i], buffers.b2[i]);
          if (scene_.lit) {
            Eigen::Vector3f n = face_normals_[face];
            Eigen::Vector3f to_camera =
                (centre - scene_.mesh.positions[scene_.mesh.faces[face][0]].cast<double>()).cast<float>();
            if (n.dot(to_camera) < 0) n = -n;  // two-sided: thin walls are lit on the side seen
            colour *= 0.3f + 0.7f * std::max(0.0f, n.dot(light));
          }
          sum += colour;
        }
      sum *= inv_samples;
      row[x] = cv::Vec3f(sum.z(), sum.y(), sum.x());  // OpenCV's BGR
    }
  });
  // Depth exactly at pixel centres.
  if (s == 1) {
    view.depth = buffers.depth.clone();
  } else {
    if (!rays_.matches(camera)) rays_ = RayTable(camera);
    renderer_.render(scene_.mesh, camera, rays_, RenderOptions{}, buffers_);
    view.depth = buffers_.depth.clone();
  }
  return view;
}

ImageEncoding image_encoding_from_string(const std::string& name) {
  if (name == "srgb8") return ImageEncoding::srgb8;
  if (name == "linear16") return ImageEncoding::linear16;
  throw UsageError("unknown image encoding \"" + name + "\" (expected srgb8 or linear16)");
}

cv::Mat to_linear16(const cv::Mat& linear) {
  cv::Mat out;
  linear.convertTo(out, CV_16UC3, 65535.0);  // saturating, rounded to nearest
  return out;
}

cv::Mat to_srgb8(const cv::Mat& linear) {
  cv::Mat out(linear.rows, linear.cols, CV_8UC3);
  std::array<std::uint8_t, 4096> table;
  for (std::size_t i = 0; i < table.size(); ++i) {
    double v = double(i) / double(table.size() - 1);
    double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
    table[i] = std::uint8_t(std::lround(255.0 * s));
  }
  tbb::parallel_for(0, linear.rows, [&](int y) {
    const float* in = linear.ptr<float>(y);
    std::uint8_t* o = out.ptr<std::uint8_t>(y);
    for (int i = 0; i < linear.cols * 3; ++i) {
      float v = std::clamp(in[i], 0.0f, 1.0f);
      o[i] = table[std::size_t(v * float(table.size() - 1) + 0.5f)];
    }
  });
  return out;
}

void write_scene(const Scene& scene, const fs::path& folder, const WriteOptions& options) {
  fs::create_directories(folder / "images");
  if (options.write_depth) fs::create_directories(folder / "depth");

  CameraSet cameras = scene.cameras;
  cameras.provenance = Provenance::current();
  {
    ScopedTimer timer("render");
    Progress progress("render", std::int64_t(cameras.cameras.size()));
    ViewRenderer renderer(scene, options.supersample);
    for (const Camera& camera : cameras.cameras) {
      RenderedView view = renderer.render(camera);
      fs::path image_path = folder / camera.image;
      write_image(image_path, options.encoding == ImageEncoding::linear16 ? to_linear16(view.color)
                                                                          : to_srgb8(view.color));
      record(image_path);
      if (options.write_depth) {
        DepthMap depth;
        depth.depth = view.depth;
        depth.kind = camera.is_perspective() ? DepthKind::perspective_z : DepthKind::spherical_range;
        depth.camera = camera;
        depth.provenance = Provenance::current();
        fs::path depth_path = folder / "depth" / (camera.id + ".exr");
        write_depth_exr(depth_path, depth);
        record(depth_path);
      }
      progress.advance();
    }
  }
  write_mesh(folder / "mesh.ply", truth_mesh_for_files(scene));
  record(folder / "mesh.ply");
  if (scene.initial_mesh) {
    Mesh initial = *scene.initial_mesh;
    initial.provenance = Provenance::current();
    write_mesh(folder / "initial.ply", initial);
    record(folder / "initial.ply");
  }
  // cameras.json last: a Make rule that depends on it sees a complete scene folder.
  nlohmann::ordered_json manifest = {{"format", "pg-synth-scene"},
                                     {"version", 1},
                                     {"provenance", to_json(Provenance::current())},
                                     {"scene", scene.name},
                                     {"units", "metres"},
                                     {"triangles", scene.mesh.faces.size()},
                                     {"views", cameras.cameras.size()},
                                     {"extras", scene.extras},
                                     {"truth_mesh", "mesh.ply"},
                                     {"cameras", "cameras.json"}};
  if (scene.initial_mesh) manifest["initial_mesh"] = "initial.ply";
  write_json_file(folder / "scene.json", manifest);
  record(folder / "scene.json");
  write_cameras(folder / "cameras.json", cameras);
  record(folder / "cameras.json");
  RunReport::global().set_metric("views", cameras.cameras.size());
  RunReport::global().set_metric("triangles", scene.mesh.faces.size());
  log::info("wrote ", scene.name, " scene: ", cameras.cameras.size(), " views, ", scene.mesh.faces.size(),
            " triangles to ", folder.string());
}

}  // namespace pg::synth
