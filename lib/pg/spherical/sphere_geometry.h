#pragma once
// Geometry of two equirectangular panoramas a baseline apart (formats/conventions.md for the
// equirectangular layout). Rotating both spheres so that the baseline points to the north pole (-y,
// the top row) makes every epipolar curve a meridian: a scene point keeps its longitude and only its
// polar angle changes, by the angular disparity gamma.
#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace pg {

// A rotation R with R * baseline pointing along -y (the rectified north pole). Among those, the one
// closest to the identity, so a baseline already along -y gives the identity. Throws UsageError for a
// zero or non-finite baseline.
Eigen::Matrix3d rectifying_rotation(const Eigen::Vector3d& baseline);

// Resamples an equirectangular image (CV_32F, any channel count) under a rotation: pixel p of the
// result shows direction d = target_from_source^T * ray(p) of the source, bilinear, wrapping across
// the longitude seam and over the poles. `size` may differ from the source's.
cv::Mat rotate_equirect(const cv::Mat& source, const Eigen::Matrix3d& target_from_source, cv::Size size);

// Range from the first sphere's centre to the point seen at polar angle theta (radians from the
// baseline direction) from the first centre and theta + gamma from the second centre, a baseline
// `baseline` further along the axis (law of sines). NaN when gamma <= 0 or theta + gamma >= pi.
double range_from_angular_disparity(double baseline, double theta, double gamma);

// The angular disparity of a point at `range` along polar angle theta (inverse of the above).
double angular_disparity_from_range(double baseline, double theta, double range);

// Pads an equirectangular image (any type) with `columns` columns on each side copied across the
// longitude seam (wrap-around), so image operators see a continuous panorama.
cv::Mat pad_longitude(const cv::Mat& image, int columns);

}  // namespace pg
