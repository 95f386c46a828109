// The OpenCL path of rasterizer_opencl.h and the device dispatch.
#include "pg/gpu/rasterizer_opencl.h"

#include <algorithm>
#include <mutex>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/opencl_runtime.h"

#if PG_GPU_HAVE_OPENCL
#include "pg/gpu/kernel_sources.h"
#endif

namespace pg::gpu {

#if PG_GPU_HAVE_OPENCL

static_assert(sizeof(PixelBox) == 4 * sizeof(int) && sizeof(std::array<PixelBox, 2>) == 2 * sizeof(PixelBox),
              "pixel boxes are uploaded as pairs of int4");

namespace {

constexpr int kTile = Renderer::kTileSize;
// Device bytes per pixel of a band: three ray components and four outputs.
constexpr std::uint64_t kBytesPerPixel = 7 * 4;
// Device bytes per face: 12 floats of planes, one flag byte, two pixel boxes, one tile-list entry
// (faces usually cover one tile; the list is counted exactly below).
constexpr std::uint64_t kBytesPerFace = 12 * 4 + 1 + 32;

// A device buffer that grows as needed and is rewritten in place otherwise.
struct GrowingBuffer {
  cl::Buffer buffer;
  std::size_t capacity = 0;
  cl::Buffer& hold(cl::Context& context, std::size_t bytes, cl_mem_flags flags) {
    bytes = std::max<std::size_t>(bytes, 4);  // OpenCL has no empty buffers
    if (bytes > capacity) {
      buffer = cl::Buffer(context, flags, bytes);
      capacity = bytes;
    }
    return buffer;
  }
  cl::Buffer& upload(cl::Context& context, cl::CommandQueue& queue, const void* data, std::size_t bytes) {
    cl::Buffer& b = hold(context, bytes, CL_MEM_READ_ONLY);
    if (bytes > 0) queue.enqueueWriteBuffer(b, CL_FALSE, 0, bytes, data);
    return b;
  }
};

}  // namespace

struct detail::RasterizerDevice {
  OpenClRuntime* runtime = nullptr;
  cl::Kernel kernel;
  cl::NDRange local = cl::NullRange;
  int band_rows = 0;       // rows rendered at once (a multiple of the tile size, or the whole image)
  int max_band_rows = 0;   // limit_band_rows; 0 = none
  bool rays_kept = false;  // the whole ray table stays uploaded (one band)
  GrowingBuffer rays[3], outputs[4], setups, flags, boxes, tile_offsets, tile_triangles;
  std::vector<float> setup_host;
  std::vector<std::uint8_t> flag_host;
};

namespace {

using Device = detail::RasterizerDevice;

void upload_rays(Device& d, const RayTable& rays, int y0, int rows) {
  cl::Context& context = d.runtime->context();
  cl::CommandQueue& queue = d.runtime->queue();
  const std::size_t offset = std::size_t(y0) * rays.width(), bytes = std::size_t(rows) * rays.width() * 4;
  const float* planes[3] = {rays.dx(), rays.dy(), rays.dz()};
  for (int c = 0; c < 3; ++c) d.rays[c].upload(context, queue, planes[c] + offset, bytes);
}

// The host's triangle setups and tile bins, repacked for the kernel and uploaded.
void upload_faces(Device& d, const Renderer& host) {
  cl::Context& context = d.runtime->context();
  cl::CommandQueue& queue = d.runtime->queue();
  const auto& setups = host.triangle_setups();
  const auto& counts = host.box_counts();
  const std::size_t faces = setups.size();
  d.setup_host.resize(12 * faces);
  d.flag_host.resize(faces);
  for (std::size_t t = 0; t < faces; ++t) {
    float* s = &d.setup_host[12 * t];
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 3; ++c) s[3 * i + c] = setups[t].edge[i][c];
    for (int c = 0; c < 3; ++c) s[9 + c] = setups[t].depth_plane[c];
    d.flag_host[t] = std::uint8_t((counts[t] << 3) | (counts[t] ? setups[t].tie : 0));
  }
  d.setups.upload(context, queue, d.setup_host.data(), d.setup_host.size() * 4);
  d.flags.upload(context, queue, d.flag_host.data(), faces);
  d.boxes.upload(context, queue, host.pixel_boxes().data(), faces * sizeof(std::array<PixelBox, 2>));
  d.tile_offsets.upload(context, queue, host.tile_offsets().data(), host.tile_offsets().size() * 4);
  d.tile_triangles.upload(context, queue, host.tile_triangles().data(), host.tile_triangles().size() * 4);
}

// Rows per band: the whole image when it fits beside the faces' data, else a multiple of the tile size.
int band_rows(const DeviceInfo& info, const Renderer& host, int width, int height) {
  const std::uint64_t faces = host.triangle_setups().size();
  const std::uint64_t face_bytes =
      faces * kBytesPerFace + 4 * host.tile_triangles().size() + 4 * host.tile_offsets().size();
  const std::uint64_t largest_face_buffer =
      std::max<std::uint64_t>(12 * 4 * faces, 4 * host.tile_triangles().size());
  // Leave a quarter of the memory to the driver and other stages.
  const std::uint64_t usable = info.global_memory / 4 * 3;
  if (face_bytes >= usable || largest_face_buffer > info.max_allocation)
    throw FailedError(str("OpenCL rasterizer: ", faces, " faces need ", face_bytes >> 20, " MiB but ",
                          info.name, " has ", info.global_memory >> 20, " MiB (largest allocation ",
                          info.max_allocation >> 20, " MiB)"));
  const std::uint64_t row_bytes = kBytesPerPixel * std::uint64_t(width);
  const std::uint64_t rows =
      std::min((usable - face_bytes) / row_bytes, info.max_allocation / (4 * std::uint64_t(width)));
  if (rows >= std::uint64_t(height)) return height;
  if (rows < std::uint64_t(kTile))
    throw FailedError(str("OpenCL rasterizer: ", info.name, " cannot hold ", kTile, " rows of ", width,
                          " pixels beside the faces' data"));
  return int(rows / kTile * kTile);
}

void rasterize(Device& d, Renderer& host, const Mesh& mesh, const Camera& camera, const RayTable& rays,
               const RenderOptions& options, RenderBuffers& out) {
  host.prepare(mesh, camera, rays, options);
  const int width = rays.width(), height = rays.height();
  int rows = band_rows(d.runtime->info(), host, width, height);
  if (d.max_band_rows > 0 && rows > d.max_band_rows) rows = std::max(kTile, d.max_band_rows / kTile * kTile);
  if (d.rays_kept && rows != d.band_rows) d.rays_kept = false;  // the faces now leave less room
  d.band_rows = rows;
  const DepthMeasure kind = resolve_depth_measure(options.depth_kind, camera);
  const std::size_t pixels = std::size_t(width) * height;
  out.width = width;
  out.height = height;
  out.depth_kind = kind;
  out.triangle.resize(pixels);
  out.b1.resize(pixels);
  out.b2.resize(pixels);
  out.depth.create(height, width, CV_32F);

  cl::Context& context = d.runtime->context();
  cl::CommandQueue& queue = d.runtime->queue();
  upload_faces(d, host);
  const std::size_t band_bytes = std::size_t(rows) * width * 4;
  for (auto& o : d.outputs) o.hold(context, band_bytes, CL_MEM_WRITE_ONLY);
  cl::Kernel& k = d.kernel;
  k.setArg(3, width), k.setArg(6, host.tiles_x()), k.setArg(7, d.tile_offsets.buffer);
  k.setArg(8, d.tile_triangles.buffer), k.setArg(9, d.setups.buffer), k.setArg(10, d.flags.buffer);
  k.setArg(11, d.boxes.buffer), k.setArg(12, float(options.near)),
      k.setArg(13, int(kind == DepthMeasure::range));
  for (int c = 0; c < 4; ++c) k.setArg(14 + c, d.outputs[c].buffer);
  for (int y0 = 0; y0 < height; y0 += rows) {
    const int band = std::min(rows, height - y0);
    if (!d.rays_kept) {
      upload_rays(d, rays, y0, band);
      d.rays_kept = band == height;
    }
    for (int c = 0; c < 3; ++c) k.setArg(c, d.rays[c].buffer);
    k.setArg(4, y0), k.setArg(5, band);
    const auto up = [](int a, int b) { return std::size_t((a + b - 1) / b * b); };
    queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(up(width, kTile), up(band, 8)), d.local);
    const std::size_t offset = std::size_t(y0) * width, bytes = std::size_t(band) * width * 4;
    queue.enqueueReadBuffer(d.outputs[0].buffer, CL_FALSE, 0, bytes, out.triangle.data() + offset);
    queue.enqueueReadBuffer(d.outputs[1].buffer, CL_FALSE, 0, bytes, out.b1.data() + offset);
    queue.enqueueReadBuffer(d.outputs[2].buffer, CL_FALSE, 0, bytes, out.b2.data() + offset);
    queue.enqueueReadBuffer(d.outputs[3].buffer, CL_TRUE, 0, bytes, out.depth.ptr<float>(y0));
  }
  host.shade(mesh, camera, rays, options, out);
}

std::unique_ptr<Device> open_device() {
  auto d = std::make_unique<Device>();
  d->runtime = detail::OpenClRuntime::get();
  if (!d->runtime) throw FailedError(str("OpenCL rasterizer: ", opencl_unavailable_reason()));
  try {
    cl::Program& program = d->runtime->program("rasterize", kernels::rasterize);
    d->kernel = cl::Kernel(program, "rasterize");
    const cl::Device device = d->runtime->context().getInfo<CL_CONTEXT_DEVICES>().front();
    // Work-groups of 32x8 pixels lie in one tile and walk the same face list.
    if (d->kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device) >= 256)
      d->local = cl::NDRange(kTile, 8);
  } catch (const cl::Error& e) {
    throw FailedError(str("OpenCL rasterizer: ", e.what(), " error ", e.err()));
  }
  return d;
}

}  // namespace

OpenClRenderer::OpenClRenderer(const RayTable& rays) : rays_(rays), device_(open_device()) {}

OpenClRenderer::~OpenClRenderer() = default;

void OpenClRenderer::render(const Mesh& mesh, const Camera& camera, const RenderOptions& options,
                            RenderBuffers& out) {
  try {
    rasterize(*device_, host_, mesh, camera, rays_, options, out);
  } catch (const cl::Error& e) {
    device_->rays_kept = false;
    throw FailedError(str("OpenCL rasterizer failed: ", e.what(), " error ", e.err()));
  }
}

void OpenClRenderer::limit_band_rows(int rows) {
  device_->max_band_rows = rows;
}

#else

struct detail::RasterizerDevice {};

OpenClRenderer::OpenClRenderer(const RayTable& rays) : rays_(rays) {
  throw FailedError(str("OpenCL rasterizer: ", opencl_unavailable_reason()));
}

OpenClRenderer::~OpenClRenderer() = default;

void OpenClRenderer::render(const Mesh&, const Camera&, const RenderOptions&, RenderBuffers&) {
  throw FailedError(str("OpenCL rasterizer: ", opencl_unavailable_reason()));
}

void OpenClRenderer::limit_band_rows(int) {}

#endif

namespace {

bool renders_with_opencl(DeviceKind device) {
  if (device == DeviceKind::automatic) device = active_device();
  return device == DeviceKind::opencl || (device == DeviceKind::cuda && opencl_unavailable_reason().empty());
}

void cpu_fallback_notice(const FailedError& e) {
  static std::once_flag notice;
  std::call_once(notice, [&] { log::warn(e.what(), "; rendering on the CPU"); });
}

}  // namespace

ViewRenderer::ViewRenderer(std::shared_ptr<const RayTable> rays, DeviceKind device)
    : rays_(std::move(rays)), device_kind_(device) {}

ViewRenderer::~ViewRenderer() = default;

void ViewRenderer::render(const Mesh& mesh, const Camera& camera, const RenderOptions& options,
                          RenderBuffers& out) {
  try {
    if (!device_chosen_) {
      device_chosen_ = true;
      if (renders_with_opencl(device_kind_)) device_ = std::make_unique<OpenClRenderer>(*rays_);
    }
    if (device_) {
      device_->render(mesh, camera, options, out);
      return;
    }
  } catch (const FailedError& e) {
    cpu_fallback_notice(e);
    device_.reset();
  }
  cpu_.render(mesh, camera, *rays_, options, out);
}

}  // namespace pg::gpu
