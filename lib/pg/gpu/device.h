#pragma once
// Where accelerated stages run. Tools take `--device cpu|opencl|cuda|auto` (the CLI frame calls
// set_requested_device); stages ask active_device() which backend to use. A request that cannot be
// met (no OpenCL ICD, no GPU, an insufficient driver, a build without CUDA) falls back — cuda to
// OpenCL to the CPU — with a one-line notice, never an error: the CPU path is the reference and
// every accelerated kernel matches it within the tolerances stated beside it.
#include <cstdint>
#include <string>
#include <vector>

namespace pg::gpu {

enum class DeviceKind { cpu, opencl, cuda, automatic };

// "cpu", "opencl", "cuda", "auto"; anything else throws UsageError.
DeviceKind parse_device_kind(const std::string& name);
std::string to_string(DeviceKind kind);

struct DeviceInfo {
  DeviceKind kind = DeviceKind::cpu;  // opencl or cuda
  int index = 0;                      // position among the devices of that kind
  std::string name, platform, driver;
  bool is_gpu = false;  // a GPU or accelerator (PoCL's CPU device is not)
  bool double_precision = false;
  std::uint64_t global_memory = 0, max_allocation = 0;  // bytes
  int compute_units = 0;
};

// Every OpenCL and CUDA device this build can use; empty when there is none.
std::vector<DeviceInfo> list_devices();
// Why no OpenCL / CUDA device is usable ("" when one is): for the listing and the fallback notice.
std::string opencl_unavailable_reason();
std::string cuda_unavailable_reason();

// The process-wide request (default automatic) and what it resolves to: cpu, opencl or cuda.
// automatic picks CUDA, else an OpenCL GPU, else the CPU (a CPU OpenCL driver such as PoCL is used
// only when asked for by name). Resolving logs the fallback notice once.
void set_requested_device(DeviceKind kind);
DeviceKind requested_device();
DeviceKind active_device();
// One line for logs and reports: "opencl (NVIDIA CUDA: NVIDIA A40)", "cpu".
std::string describe_active_device();
// The active device's properties (memory limits for stages that size their uploads); on the CPU a
// default DeviceInfo (kind cpu, no memory figures).
DeviceInfo active_device_info();
// Whether a stage has asked for the active device since the last request (the CLI frame reports
// the device only then, so tools without accelerated stages never initialise a driver).
bool device_resolved();

}  // namespace pg::gpu
