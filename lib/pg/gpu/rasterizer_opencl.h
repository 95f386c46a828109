#pragma once
// The rasterizer (pg/render/rasterizer.h) on an OpenCL device. The host computes what the CPU renderer
// computes before its per-pixel loop (Renderer::prepare: the faces' edge and depth planes, tie bits,
// pixel boxes and 32x32 tile bins, with the CPU's own code); the device runs that loop, one work-item
// per pixel testing its tile's faces in the same order with the same float operations (no FMA
// contraction, correctly rounded division). Depth, face ids and barycentrics therefore equal
// Renderer::render's bit for bit on a device that rounds as IEEE 754 requires (PoCL, NVIDIA, AMD);
// the tests accept 1e-4 (relative depth, barycentrics) and equal ids on 99.9% of the pixels.
// Shading, when asked for, runs on the host (Renderer::shade) from the device's buffers.
#include <memory>

#include "pg/gpu/device.h"
#include "pg/render/rasterizer.h"

namespace pg::gpu {

namespace detail {
struct RasterizerDevice;  // the kernel and buffers (rasterizer_opencl.cpp)
}

// One view: keeps its ray table on the device between renders (uploaded once, when the image fits the
// device in one band; taller images are rendered in bands of rows, each band's rays uploaded per
// render). Throws FailedError when no OpenCL device is usable, on a driver error, or when the faces'
// data alone exceed the device's memory.
class OpenClRenderer {
 public:
  // `rays` is not copied: it must outlive this renderer and stay unchanged.
  explicit OpenClRenderer(const RayTable& rays);
  ~OpenClRenderer();
  OpenClRenderer(const OpenClRenderer&) = delete;
  OpenClRenderer& operator=(const OpenClRenderer&) = delete;

  // Renderer::render(mesh, camera, rays, options, out) with the rays given at construction.
  void render(const Mesh& mesh, const Camera& camera, const RenderOptions& options, RenderBuffers& out);
  // Renders in bands of at most `rows` rows (rounded down to a multiple of the tile size, at least one
  // tile), as on a device too small for the image; 0 = as many as the device holds. For the tests.
  void limit_band_rows(int rows);

 private:
  const RayTable& rays_;
  Renderer host_;
  std::unique_ptr<detail::RasterizerDevice> device_;
};

// One view rendered again and again (pg-refine's iterations) on `device` (automatic = the active
// device, resolved at the first render). opencl and cuda run the OpenCL kernel (there is no CUDA
// rasterizer; NVIDIA's driver ships OpenCL) through an OpenClRenderer that keeps the view's ray table
// uploaded between renders; cpu is exactly Renderer::render. Without a usable OpenCL device, or once
// the device fails (memory, driver), every render runs on the CPU after a one-time notice.
class ViewRenderer {
 public:
  explicit ViewRenderer(std::shared_ptr<const RayTable> rays, DeviceKind device = DeviceKind::automatic);
  ~ViewRenderer();
  ViewRenderer(const ViewRenderer&) = delete;
  ViewRenderer& operator=(const ViewRenderer&) = delete;

  void render(const Mesh& mesh, const Camera& camera, const RenderOptions& options, RenderBuffers& out);
  bool on_device() const { return device_ != nullptr; }

 private:
  std::shared_ptr<const RayTable> rays_;
  Renderer cpu_;
  DeviceKind device_kind_;
  std::unique_ptr<OpenClRenderer> device_;
  bool device_chosen_ = false;
};

}  // namespace pg::gpu
