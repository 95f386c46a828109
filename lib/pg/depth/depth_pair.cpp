#include "pg/depth/depth_pair.h"

#include <chrono>
#include <opencv2/imgproc.hpp>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/depth/depth_geometry.h"

namespace pg {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

cv::Mat resized(const cv::Mat& image, cv::Size size, int interpolation) {
  if (image.empty() || image.size() == size) return image;
  cv::Mat out;
  cv::resize(image, out, size, 0, 0, interpolation);
  return out;
}

void check_image(const cv::Mat& image, const Camera& camera, const char* what) {
  if (image.empty()) throw UsageError(str("depth: the ", what, " image is empty"));
  if (image.cols != camera.width || image.rows != camera.height)
    throw UsageError(str("depth: the ", what, " image is ", image.cols, "x", image.rows, " but camera '",
                         camera.id, "' is ", camera.width, "x", camera.height));
}

}  // namespace

void DepthPairOptions::check() const {
  flow.check();
  filter.check();
  if (!(scale > 0 && scale <= 1)) throw UsageError(str("depth scale ", scale, " is not in (0, 1]"));
  if (fill_occlusions && !epipolar) throw UsageError("filling occlusions needs the epipolar flow mode");
}

DepthPairResult compute_depth_pair(const DepthPairInput& input, const DepthPairOptions& options) {
  options.check();
  check_image(input.reference_image, input.reference, "reference");
  check_image(input.other_image, input.other, "other");
  if (input.reference_image.channels() != input.other_image.channels())
    throw UsageError("depth: the two images have different channel counts");
  const Camera reference =
      options.scale == 1 ? input.reference : resized_camera(input.reference, options.scale);
  const Camera other = options.scale == 1 ? input.other : resized_camera(input.other, options.scale);
  const cv::Size ref_size(reference.width, reference.height), other_size(other.width, other.height);
  const cv::Mat ref_image = resized(input.reference_image, ref_size, cv::INTER_AREA);
  const cv::Mat other_image = resized(input.other_image, other_size, cv::INTER_AREA);
  if (ref_size != other_size)
    throw UsageError("depth: the flow needs both views at the same size (" + reference.id + ", " + other.id +
                     ")");

  DepthPairResult result;
  const auto flow_start = std::chrono::steady_clock::now();
  const EpipolarField forward_field = options.epipolar ? epipolar_field(reference, other) : EpipolarField{};
  BidirectionalFlow flow =
      options.epipolar ? compute_epipolar_flow_bidirectional(ref_image, other_image, forward_field,
                                                             epipolar_field(other, reference), options.flow)
                       : compute_flow_bidirectional(ref_image, other_image, options.flow);
  cv::Mat1b filled;
  if (options.fill_occlusions) {  // the pixels the depth filter's own consistency check rejects
    const cv::Mat1b occluded =
        occlusion_mask(flow.fb_error, flow.forward, options.filter.max_fb_error, fb_error_per_flow);
    const cv::Mat2f filled_flow = fill_occlusions_along_lines(flow.forward, occluded, forward_field);
    // A hidden pixel with no background along its line keeps its own flow, which failed the check:
    // it is not filled, and the check still applies to it.
    filled = cv::Mat1b(occluded.size(), uchar(0));
    for (int y = 0; y < filled.rows; ++y)
      for (int x = 0; x < filled.cols; ++x)
        filled(y, x) = occluded(y, x) && filled_flow(y, x) != flow.forward(y, x) ? 255 : 0;
    flow.forward = filled_flow;
    result.filled = static_cast<std::size_t>(cv::countNonZero(filled));
  }
  result.flow_seconds = seconds_since(flow_start);

  const auto triangulation_start = std::chrono::steady_clock::now();
  DepthFromFlowInput depth_input;
  depth_input.reference = &reference;
  depth_input.other = &other;
  depth_input.flow = flow.forward;
  depth_input.fb_error = flow.fb_error;
  depth_input.filled = filled;
  depth_input.reference_mask = resized(input.reference_mask, ref_size, cv::INTER_NEAREST);
  depth_input.other_mask = resized(input.other_mask, other_size, cv::INTER_NEAREST);
  depth_input.texture = local_texture(ref_image);
  result.depth = depth_from_flow(depth_input, options.filter);
  result.triangulation_seconds = seconds_since(triangulation_start);
  result.flow = flow.forward;
  return result;
}

}  // namespace pg
