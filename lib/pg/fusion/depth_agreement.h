#pragma once
// How well a merged surface explains a depth frame: the fraction of valid depth pixels whose ray
// meets the mesh within a tolerance of the measured depth (measured along the ray).
#include "pg/fusion/depth_frame.h"
#include "pg/mesh/bvh.h"

namespace pg::fusion {

struct DepthAgreement {
  std::size_t valid_pixels = 0;  // finite depth (masks and weights ignored)
  std::size_t agreeing = 0;      // the first mesh hit along the ray lies within the tolerance
  std::size_t in_front = 0;      // the first hit is nearer than the depth less the tolerance
  std::size_t missed = 0;        // no hit before the depth plus the tolerance (a hole, or too far)
  double fraction() const { return valid_pixels ? double(agreeing) / double(valid_pixels) : 0.0; }
  DepthAgreement& operator+=(const DepthAgreement& other) {
    valid_pixels += other.valid_pixels;
    agreeing += other.agreeing;
    in_front += other.in_front;
    missed += other.missed;
    return *this;
  }
};

DepthAgreement depth_agreement(const TriangleBvh& mesh, const DepthFrame& frame, double tolerance);

}  // namespace pg::fusion
