#include "pg/gpu/opencl_runtime.h"

#if PG_GPU_HAVE_OPENCL
#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::gpu::detail {
namespace {

DeviceInfo describe(const cl::Platform& platform, const cl::Device& device, int index) {
  DeviceInfo info;
  info.kind = DeviceKind::opencl;
  info.index = index;
  info.name = device.getInfo<CL_DEVICE_NAME>();
  info.platform = platform.getInfo<CL_PLATFORM_NAME>();
  info.driver = device.getInfo<CL_DRIVER_VERSION>();
  info.is_gpu = (device.getInfo<CL_DEVICE_TYPE>() & (CL_DEVICE_TYPE_GPU | CL_DEVICE_TYPE_ACCELERATOR)) != 0;
  info.double_precision = device.getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() != 0;
  info.global_memory = device.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
  info.max_allocation = device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
  info.compute_units = int(device.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>());
  // Names carry trailing spaces or NULs on some drivers.
  for (std::string* s : {&info.name, &info.platform, &info.driver})
    while (!s->empty() && (s->back() == ' ' || s->back() == '\0')) s->pop_back();
  return info;
}

}  // namespace

std::vector<std::pair<cl::Device, DeviceInfo>> opencl_devices(std::string& reason) {
  std::vector<std::pair<cl::Device, DeviceInfo>> devices;
  try {
    std::vector<cl::Platform> platforms;
    cl::Platform::get(&platforms);
    for (const auto& platform : platforms) {
      std::vector<cl::Device> found;
      try {
        platform.getDevices(CL_DEVICE_TYPE_ALL, &found);
      } catch (const cl::Error&) {
        continue;  // a platform without devices (an ICD whose driver finds no hardware)
      }
      for (const auto& device : found)
        devices.emplace_back(device, describe(platform, device, int(devices.size())));
    }
    if (devices.empty()) reason = "no OpenCL device found";
  } catch (const cl::Error& e) {
    reason = str("no OpenCL platform (", e.what(), " error ", e.err(), ")");
  }
  return devices;
}

OpenClRuntime* OpenClRuntime::get() {
  static OpenClRuntime* runtime = []() -> OpenClRuntime* {
    std::string reason;
    auto devices = opencl_devices(reason);
    if (devices.empty()) return nullptr;
    // The first GPU, else the first device.
    auto chosen = devices.begin();
    for (auto it = devices.begin(); it != devices.end(); ++it)
      if (it->second.is_gpu) {
        chosen = it;
        break;
      }
    try {
      return new OpenClRuntime(chosen->first, chosen->second);  // lives as long as the process
    } catch (const cl::Error& e) {
      log::debug("OpenCL device ", chosen->second.name, " unusable: ", e.what(), " error ", e.err());
      return nullptr;
    }
  }();
  return runtime;
}

OpenClRuntime::OpenClRuntime(cl::Device device, DeviceInfo info)
    : device_(device), context_(device), queue_(context_, device), info_(std::move(info)) {}

cl::Program& OpenClRuntime::program(const std::string& name, const char* source) {
  std::lock_guard lock(mutex_);
  auto it = programs_.find(name);
  if (it != programs_.end()) return it->second;
  cl::Program program(context_, std::string(source));
  const std::string options =
      info_.double_precision
          ? "-cl-std=CL1.2 -cl-fp32-correctly-rounded-divide-sqrt -DPG_REAL=double -DPG_HAVE_FP64=1"
          : "-cl-std=CL1.2 -cl-fp32-correctly-rounded-divide-sqrt -DPG_REAL=float -DPG_HAVE_FP64=0";
  try {
    program.build({device_}, options.c_str());
  } catch (const cl::Error&) {
    throw FailedError(str("OpenCL kernel ", name, " failed to build on ", info_.name, ":\n",
                          program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_)));
  }
  return programs_.emplace(name, std::move(program)).first->second;
}

}  // namespace pg::gpu::detail
#endif
