#pragma once
// Internal: the OpenCL context, queue and compiled programs of the selected device. Only built with
// OpenCL (PG_GPU_HAVE_OPENCL); callers go through device.h and the stage functions.
#if PG_GPU_HAVE_OPENCL
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>
#include <map>
#include <mutex>
#include <string>

#include "pg/gpu/device.h"

namespace pg::gpu::detail {

class OpenClRuntime {
 public:
  // The process-wide runtime on the preferred device (a GPU when there is one), or nullptr when no
  // OpenCL device is usable; the reason is then opencl_unavailable_reason().
  static OpenClRuntime* get();

  cl::Context& context() { return context_; }
  cl::CommandQueue& queue() { return queue_; }
  const DeviceInfo& info() const { return info_; }
  // The program built from an embedded source (kernel_sources.h), compiled once. `real` is double
  // where the device has fp64 (matching the CPU reference's double arithmetic), else float.
  cl::Program& program(const std::string& name, const char* source);

 private:
  OpenClRuntime(cl::Device device, DeviceInfo info);
  cl::Device device_;
  cl::Context context_;
  cl::CommandQueue queue_;
  DeviceInfo info_;
  std::mutex mutex_;
  std::map<std::string, cl::Program> programs_;
};

// Enumerates all OpenCL devices; fills `reason` when there are none.
std::vector<std::pair<cl::Device, DeviceInfo>> opencl_devices(std::string& reason);

}  // namespace pg::gpu::detail
#endif
