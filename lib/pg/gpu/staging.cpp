#include "pg/gpu/staging.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>

namespace pg::gpu::detail {

PlaneSource plane_source(const cv::Mat& m) {
  return {m.ptr<float>(), m.total() * std::size_t(m.channels())};
}

std::vector<PlaneSource> tensor_sources(const std::array<cv::Mat1f, 6>& tensor) {
  std::vector<PlaneSource> planes;
  for (const cv::Mat1f& entry : tensor) planes.push_back(plane_source(entry));
  return planes;
}

std::vector<PlaneSource> upload_planes(const FlowIncrementInput& in) {
  std::vector<PlaneSource> planes = tensor_sources(in.brightness), gradient = tensor_sources(in.gradient);
  planes.insert(planes.end(), gradient.begin(), gradient.end());
  for (const cv::Mat1f* m : {&in.u, &in.v, &in.smoothness}) planes.push_back(plane_source(*m));
  return planes;
}

std::vector<PlaneSource> upload_planes(const LineIncrementInput& in) {
  std::vector<PlaneSource> planes = tensor_sources(in.brightness), gradient = tensor_sources(in.gradient);
  planes.insert(planes.end(), gradient.begin(), gradient.end());
  for (const cv::Mat* m : std::initializer_list<const cv::Mat*>{&in.s, &in.smoothness, &in.direction})
    planes.push_back(plane_source(*m));
  return planes;
}

std::size_t total_floats(const std::vector<PlaneSource>& planes) {
  std::size_t total = 0;
  for (const PlaneSource& p : planes) total += p.floats;
  return total;
}

void gather(const std::vector<PlaneSource>& planes, float* destination) {
  // Chunks of 64k floats, so that a few large planes still spread over every thread.
  constexpr std::size_t chunk = 1 << 16;
  std::vector<std::size_t> offsets{0};
  for (const PlaneSource& p : planes) offsets.push_back(offsets.back() + p.floats);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, (offsets.back() + chunk - 1) / chunk),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c) {
          const std::size_t begin = c * chunk, end = std::min(begin + chunk, offsets.back());
          // The planes this chunk of the destination overlaps.
          auto k = std::size_t(std::upper_bound(offsets.begin(), offsets.end(), begin) - offsets.begin() - 1);
          for (std::size_t at = begin; at < end; ++k) {
            const std::size_t stop = std::min(end, offsets[k + 1]);
            std::memcpy(destination + at, planes[k].data + (at - offsets[k]), (stop - at) * sizeof(float));
            at = stop;
          }
        }
      });
}

}  // namespace pg::gpu::detail
