#pragma once
// Local features of one frame: SIFT keypoints and descriptors (compared as RootSIFT), descriptor
// matching with the ratio test and a mutual check, and robust two-view verification by a fundamental matrix.
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace pg {

// A point's local image frame as its detector saw it: scale (keypoint diameter, pixels) and
// orientation (degrees, OpenCV's keypoint convention). Size 0: unknown.
struct PointShape {
  float size = 0;
  float angle_deg = 0;
};

struct FrameFeatures {
  std::vector<cv::Point2f> points;  // working-image pixels, pixel (0, 0) the centre of the top-left pixel
  std::vector<PointShape> shapes;   // parallel to points
  std::vector<float> responses;     // detector strength, for picking the strongest subset
  // CV_8U, one SIFT row per point: OpenCV's descriptor, whose values are whole numbers up to 255, kept
  // exactly in a byte each (a quarter of the memory of floats) and made RootSIFT when matched.
  cv::Mat descriptors;
};

// SIFT on an 8-bit grey image; `mask` (8-bit, same size, non-zero = usable) may be empty. Keeps at
// most max_features, the strongest first.
FrameFeatures detect_sift(const cv::Mat& gray8, const cv::Mat& mask, int max_features,
                          double contrast_threshold = 0.02);

// Bytes detect_sift holds while it runs on a `size` image: OpenCV's scale space on the doubled image,
// 6 Gaussian and 5 difference-of-Gaussian float levels an octave, the octaves together 4/3 of the
// first: about 235 bytes a pixel, and a sixteenth more for the rest. build_correspondences runs only
// as many detections at once as memory allows.
std::uint64_t sift_detection_bytes(cv::Size size);

// Bytes FrameFeatures holds a feature: its descriptor, point, shape and response.
inline constexpr std::uint64_t sift_feature_bytes =
    128 * sizeof(std::uint8_t) + sizeof(cv::Point2f) + sizeof(PointShape) + sizeof(float);

// RootSIFT (Arandjelovic and Zisserman 2012) of CV_8U SIFT rows, as CV_32F rows: L1-normalised, then
// square-rooted. Euclidean distance between the results compares descriptors by the Hellinger
// kernel, which matches more reliably than L2 on SIFT.
cv::Mat root_sift(const cv::Mat& sift8);

// The `count` strongest features (all when count >= size).
FrameFeatures strongest_features(const FrameFeatures& features, int count);

struct FeatureMatch {
  int a = 0, b = 0;  // indices into the two frames' features
};

// Nearest-neighbour matches a -> b that pass Lowe's ratio test and, with `mutual`, whose match b -> a
// is the same pair. Exhaustive and exact (every pair of descriptors is compared, as COLMAP does), so
// the matches are a function of the descriptors alone. Descriptors are CV_32F rows.
std::vector<FeatureMatch> match_descriptors(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                                            double ratio = 0.8, bool mutual = true);

// match_descriptors on two frames' features, compared as RootSIFT.
std::vector<FeatureMatch> match_features(const FrameFeatures& a, const FrameFeatures& b, double ratio = 0.8,
                                         bool mutual = true);

// Inlier flags of a RANSAC fundamental matrix (Sampson distance below threshold_px). All false when
// fewer than 8 pairs or no model is found.
std::vector<bool> fundamental_inliers(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                                      double threshold_px, cv::Mat* fundamental = nullptr);

}  // namespace pg
