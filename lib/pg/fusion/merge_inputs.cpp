#include "pg/fusion/merge_inputs.h"

#include "pg/core/error.h"
#include "pg/core/log.h"

namespace pg::fusion {

DepthFrame load_frame(const MergeInput& input, const InputSettings& settings) {
  if (input.kind == InputKind::scan)
    throw UsageError(str(input.path.string(), " is a scan, not a depth image"));
  const DepthMap map = input.kind == InputKind::depth_exr
                           ? read_depth_exr(input.path)
                           : read_rgbd_depth(input.path, input.camera, settings.depth_scale);
  WeightOptions weights = settings.weights;
  weights.multiplier = input.multiplier;
  const cv::Mat mask = input.mask.empty() ? cv::Mat() : read_mask_image(input.mask);
  const cv::Mat color = input.color.empty() ? cv::Mat() : cv::Mat(read_color_image(input.color));
  return make_depth_frame(map, input.path, weights, mask, color, input.mask);
}

void integrate_input(TsdfVolume& volume, const MergeInput& input, const InputSettings& settings) {
  if (input.kind != InputKind::scan) {
    volume.integrate(load_frame(input, settings));
    return;
  }
  if (inspect_scan(input.path).kind == ScanKind::points) {
    ScanPoints points = place_scan_points(read_scan_points(input.path), input.world_from_scan,
                                          input.sensor_origin, input.sensor_direction);
    const WeightOptions& w = settings.weights;
    points.multiplier = input.multiplier;
    points.use_angle = w.use_angle;
    points.min_cos = w.min_cos;
    points.use_confidence = w.use_confidence;
    points.max_range = w.max_depth;
    volume.integrate(points);
    return;
  }
  ScanSurface scan = place_scan(read_scan_mesh(input.path, settings.max_edge_factor), input.world_from_scan,
                                input.sensor_origin, input.sensor_direction, input.path.string());
  scan.multiplier = input.multiplier;
  scan.min_cos = settings.weights.min_cos;
  volume.integrate(scan);
}

}  // namespace pg::fusion
