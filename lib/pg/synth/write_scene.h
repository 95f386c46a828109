#pragma once
// Renders a synthetic scene's views and writes everything with its ground truth:
//   cameras.json, images/<id>.png (8-bit sRGB or 16-bit linear), depth/<id>.exr, mesh.ply (truth, vertex
//   colours), initial.ply (deform scene), scene.json (format "pg-synth-scene": name, seed, scene facts,
//   files).
// One view at a time is held in memory.
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "pg/camera/camera.h"
#include "pg/render/rasterizer.h"
#include "pg/synth/scenes.h"

namespace pg::synth {

// How images/<id>.png store the anti-aliased linear render.
enum class ImageEncoding {
  srgb8,     // 8-bit sRGB, as a camera's JPEG
  linear16,  // 16-bit linear light: the box filter's pixel values as they are, for measurements (a
             // corner detector's sub-pixel fit models a pixel as the mean light over its area)
};
ImageEncoding image_encoding_from_string(const std::string& name);  // "srgb8", "linear16"; UsageError

struct WriteOptions {
  int supersample = 3;  // samples per pixel side (box filter over the pixel's area)
  ImageEncoding encoding = ImageEncoding::srgb8;
  bool write_depth = true;
};

struct RenderedView {
  cv::Mat color;  // CV_32FC3 linear BGR, anti-aliased
  cv::Mat depth;  // CV_32F at pixel centres: z for perspective cameras, range for panoramas; NaN = empty
};

// Renders views of one scene, reusing ray tables across views with the same intrinsics and size.
class ViewRenderer {
 public:
  ViewRenderer(const Scene& scene, int supersample);
  RenderedView render(const Camera& camera);

 private:
  const Scene& scene_;
  int supersample_;
  std::vector<Eigen::Vector3f> face_normals_;
  RayTable fine_rays_, rays_;
  Renderer renderer_;
  RenderBuffers fine_buffers_, buffers_;
};

// Linear [0,1] float BGR -> 8-bit sRGB-encoded BGR.
cv::Mat to_srgb8(const cv::Mat& linear);
// Linear [0,1] float BGR -> 16-bit linear BGR (0..65535, rounded).
cv::Mat to_linear16(const cv::Mat& linear);

void write_scene(const Scene& scene, const std::filesystem::path& folder, const WriteOptions& options);

}  // namespace pg::synth
