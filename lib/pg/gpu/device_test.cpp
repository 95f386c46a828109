#include <gtest/gtest.h>

#include "pg/core/error.h"
#include "pg/gpu/device.h"

namespace pg::gpu {
namespace {

TEST(Device, ParsesEveryNameAndRejectsOthers) {
  for (DeviceKind kind : {DeviceKind::cpu, DeviceKind::opencl, DeviceKind::cuda, DeviceKind::automatic})
    EXPECT_EQ(parse_device_kind(to_string(kind)), kind);
  EXPECT_THROW(parse_device_kind("gpu"), UsageError);
}

TEST(Device, CpuRequestStaysOnTheCpu) {
  set_requested_device(DeviceKind::cpu);
  EXPECT_EQ(active_device(), DeviceKind::cpu);
  EXPECT_EQ(describe_active_device(), "cpu");
  set_requested_device(DeviceKind::automatic);
}

TEST(Device, OpenClRequestUsesAListedDeviceOrFallsBackToTheCpu) {
  set_requested_device(DeviceKind::opencl);
  const bool have_opencl = opencl_unavailable_reason().empty();
  EXPECT_EQ(active_device(), have_opencl ? DeviceKind::opencl : DeviceKind::cpu);
  const auto devices = list_devices();
  bool listed = false;
  for (const auto& d : devices) listed = listed || (d.kind == DeviceKind::opencl && !d.name.empty());
  EXPECT_EQ(listed, have_opencl);
  set_requested_device(DeviceKind::automatic);
}

TEST(Device, CudaRequestFallsBackWhereNoCudaDeviceIsUsable) {
  set_requested_device(DeviceKind::cuda);
  const DeviceKind active = active_device();
  if (cuda_unavailable_reason().empty())
    EXPECT_EQ(active, DeviceKind::cuda);
  else
    EXPECT_EQ(active, opencl_unavailable_reason().empty() ? DeviceKind::opencl : DeviceKind::cpu);
  set_requested_device(DeviceKind::automatic);
}

TEST(Device, AutomaticNeverPicksACpuOpenClDriver) {
  set_requested_device(DeviceKind::automatic);
  if (active_device() == DeviceKind::opencl) {
    bool gpu = false;
    for (const auto& d : list_devices()) gpu = gpu || (d.kind == DeviceKind::opencl && d.is_gpu);
    EXPECT_TRUE(gpu);
  }
}

}  // namespace
}  // namespace pg::gpu
