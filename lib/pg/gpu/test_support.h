#pragma once
// Test helper: skips an OpenCL comparison with a message where no OpenCL device is usable.
#include <gtest/gtest.h>

#include "pg/gpu/device.h"

#define PG_REQUIRE_OPENCL()                                                                    \
  do {                                                                                         \
    const std::string reason = pg::gpu::opencl_unavailable_reason();                           \
    if (!reason.empty()) GTEST_SKIP() << "no OpenCL device (" << reason << "); CPU path only"; \
  } while (false)
