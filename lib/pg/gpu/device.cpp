#include "pg/gpu/device.h"

#include <atomic>
#include <mutex>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/gpu/cuda_backend.h"
#include "pg/gpu/opencl_runtime.h"

namespace pg::gpu {
namespace {

std::atomic<DeviceKind> requested{DeviceKind::automatic};

struct Resolution {
  DeviceKind active = DeviceKind::cpu;
  std::string description = "cpu";
  DeviceInfo info;
};

bool opencl_usable(bool gpu_only, Resolution& r) {
#if PG_GPU_HAVE_OPENCL
  auto* runtime = detail::OpenClRuntime::get();
  if (!runtime || (gpu_only && !runtime->info().is_gpu)) return false;
  r.description = str("opencl (", runtime->info().platform, ": ", runtime->info().name, ")");
  r.info = runtime->info();
  return true;
#else
  (void)gpu_only;
  (void)r;
  return false;
#endif
}

bool cuda_usable(Resolution& r) {
  std::string reason;
  const auto devices = detail::cuda_devices(reason);
  if (devices.empty()) return false;
  r.description = str("cuda (", devices.front().name, ")");
  r.info = devices.front();
  return true;
}

Resolution resolve(DeviceKind kind) {
  Resolution r;
  if (kind == DeviceKind::cpu) return r;
  if ((kind == DeviceKind::cuda || kind == DeviceKind::automatic) && cuda_usable(r)) {
    r.active = DeviceKind::cuda;
    return r;
  }
  if (opencl_usable(kind == DeviceKind::automatic, r)) {
    r.active = DeviceKind::opencl;
    if (kind == DeviceKind::cuda)
      log::warn("--device cuda: ", cuda_unavailable_reason(), "; using ", r.description, " instead");
    return r;
  }
  if (kind == DeviceKind::cuda)
    log::warn("--device cuda: ", cuda_unavailable_reason(), "; no OpenCL device either, using the CPU");
  else if (kind == DeviceKind::opencl)
    log::warn("--device opencl: ", opencl_unavailable_reason(), "; using the CPU");
  return r;
}

std::mutex resolution_mutex;
DeviceKind resolved_for = DeviceKind::automatic;
bool resolved = false;
Resolution resolution;

const Resolution& current() {
  std::lock_guard lock(resolution_mutex);
  if (!resolved || resolved_for != requested.load()) {
    resolved_for = requested.load();
    resolution = resolve(resolved_for);
    resolved = true;
    log::info("device: ", resolution.description);
  }
  return resolution;
}

}  // namespace

DeviceKind parse_device_kind(const std::string& name) {
  if (name == "cpu") return DeviceKind::cpu;
  if (name == "opencl") return DeviceKind::opencl;
  if (name == "cuda") return DeviceKind::cuda;
  if (name == "auto") return DeviceKind::automatic;
  throw UsageError(str("unknown device '", name, "' (expected cpu, opencl, cuda or auto)"));
}

std::string to_string(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::cpu:
      return "cpu";
    case DeviceKind::opencl:
      return "opencl";
    case DeviceKind::cuda:
      return "cuda";
    case DeviceKind::automatic:
      return "auto";
  }
  return "?";
}

std::vector<DeviceInfo> list_devices() {
  std::string reason;
  std::vector<DeviceInfo> devices = detail::cuda_devices(reason);
#if PG_GPU_HAVE_OPENCL
  for (auto& [device, info] : detail::opencl_devices(reason)) devices.push_back(info);
#endif
  return devices;
}

std::string opencl_unavailable_reason() {
#if PG_GPU_HAVE_OPENCL
  std::string reason;
  if (detail::opencl_devices(reason).empty()) return reason;
  return detail::OpenClRuntime::get() ? "" : "the OpenCL device could not be initialised";
#else
  return "this build has no OpenCL support (PG_WITH_OPENCL=OFF or no OpenCL found)";
#endif
}

std::string cuda_unavailable_reason() {
  std::string reason;
  return detail::cuda_devices(reason).empty() ? reason : "";
}

void set_requested_device(DeviceKind kind) {
  requested = kind;
}
DeviceKind requested_device() {
  return requested;
}
DeviceKind active_device() {
  return current().active;
}
std::string describe_active_device() {
  return current().description;
}
DeviceInfo active_device_info() {
  return current().info;
}

bool device_resolved() {
  std::lock_guard lock(resolution_mutex);
  return resolved && resolved_for == requested.load();
}

}  // namespace pg::gpu
