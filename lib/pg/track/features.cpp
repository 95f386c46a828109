#include "pg/track/features.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "pg/track/descriptor_dots.h"

namespace pg {

cv::Mat root_sift(const cv::Mat& sift8) {
  CV_Assert(sift8.type() == CV_8U);
  cv::Mat out(sift8.rows, sift8.cols, CV_32F);
  for (int r = 0; r < sift8.rows; ++r) {
    const std::uint8_t* in = sift8.ptr<std::uint8_t>(r);
    float* row = out.ptr<float>(r);
    float sum = 0;
    for (int c = 0; c < sift8.cols; ++c) sum += static_cast<float>(in[c]);
    const float inv = sum > 0 ? 1.0f / sum : 0.0f;
    for (int c = 0; c < sift8.cols; ++c) row[c] = std::sqrt(static_cast<float>(in[c]) * inv);
  }
  return out;
}

FrameFeatures detect_sift(const cv::Mat& gray8, const cv::Mat& mask, int max_features,
                          double contrast_threshold) {
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(0, 3, contrast_threshold, 10, 1.6);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  sift->detectAndCompute(gray8, mask, keypoints, descriptors);
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int i, int j) { return keypoints[i].response > keypoints[j].response; });
  if (max_features > 0 && order.size() > static_cast<std::size_t>(max_features)) order.resize(max_features);
  FrameFeatures out;
  out.descriptors.create(static_cast<int>(order.size()), descriptors.cols > 0 ? descriptors.cols : 128,
                         CV_8U);
  for (std::size_t k = 0; k < order.size(); ++k) {
    // OpenCV's SIFT doubles the image first (INTER_LINEAR, pixel centres at i / 2 - 0.25) but halves
    // keypoint coordinates without the offset: every keypoint sits 0.25 px right of and below its place.
    out.points.push_back(keypoints[order[k]].pt - cv::Point2f(0.25f, 0.25f));
    out.shapes.push_back({keypoints[order[k]].size, keypoints[order[k]].angle});
    out.responses.push_back(keypoints[order[k]].response);
    // OpenCV's float SIFT values are whole numbers up to 255 (Features.StoredDescriptorsAreOpenCvsExactly).
    descriptors.row(order[k]).convertTo(out.descriptors.row(static_cast<int>(k)), CV_8U);
  }
  return out;
}

std::uint64_t sift_detection_bytes(cv::Size size) {
  constexpr std::uint64_t levels = 6 + 5, float_bytes = 4, doubled = 4;
  const std::uint64_t first_octave = doubled * std::uint64_t(size.area()) * levels * float_bytes;
  // A sixteenth more for the keypoints, descriptors and per-thread buffers: 1496 MiB at 3072x2048,
  // where 1412 were measured.
  return first_octave * 4 / 3 * 17 / 16;
}

FrameFeatures strongest_features(const FrameFeatures& features, int count) {
  // detect_sift stores features strongest first.
  const int n = std::min<int>(count, static_cast<int>(features.points.size()));
  FrameFeatures out;
  out.points.assign(features.points.begin(), features.points.begin() + n);
  out.shapes.assign(features.shapes.begin(), features.shapes.begin() + n);
  out.responses.assign(features.responses.begin(), features.responses.begin() + n);
  out.descriptors = features.descriptors.rowRange(0, n).clone();
  return out;
}

std::vector<FeatureMatch> match_descriptors(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                                            double ratio, bool mutual) {
  CV_Assert(descriptors_a.type() == CV_32F && descriptors_b.type() == CV_32F);
  std::vector<FeatureMatch> matches;
  const cv::Mat a = descriptors_a.isContinuous() ? descriptors_a : descriptors_a.clone();
  const cv::Mat b = descriptors_b.isContinuous() ? descriptors_b : descriptors_b.clone();
  if (a.rows < 2 || b.rows < 2) return matches;
  const auto squared_norms = [](const cv::Mat& m) {
    std::vector<float> norms(m.rows);
    for (int r = 0; r < m.rows; ++r) norms[r] = static_cast<float>(m.row(r).dot(m.row(r)));
    return norms;
  };
  const std::vector<float> norm_a = squared_norms(a), norm_b = squared_norms(b);
  constexpr float none = std::numeric_limits<float>::max();
  // Per row of a: its nearest and second-nearest rows of b; per row of b: its nearest row of a. Ties
  // keep the lower index (tiles are visited in index order, and only a strictly closer row replaces).
  std::vector<float> first(a.rows, none), second(a.rows, none), nearest_to_b(b.rows, none);
  std::vector<int> first_index(a.rows, -1), nearest_to_b_index(b.rows, -1);
  // Tiles sized for the caches: 64 rows of a (32 KiB) against 256 rows of b (128 KiB).
  constexpr int tile_a = 64, tile_b = 256;
  std::vector<float> dots(static_cast<std::size_t>(tile_a) * tile_b);
  for (int i0 = 0; i0 < a.rows; i0 += tile_a) {
    const int rows_a = std::min(tile_a, a.rows - i0);
    for (int j0 = 0; j0 < b.rows; j0 += tile_b) {
      const int rows_b = std::min(tile_b, b.rows - j0);
      descriptor_dots(a.ptr<float>(i0), rows_a, b.ptr<float>(j0), rows_b, a.cols, dots.data(), tile_b);
      for (int i = 0; i < rows_a; ++i) {
        const float* row = dots.data() + static_cast<std::size_t>(i) * tile_b;
        const float na = norm_a[i0 + i];
        float d1 = first[i0 + i], d2 = second[i0 + i];
        int j1 = first_index[i0 + i];
        for (int j = 0; j < rows_b; ++j) {
          const float d = std::max(0.0f, na + norm_b[j0 + j] - 2 * row[j]);  // squared distance
          if (d < d1) {
            d2 = d1, d1 = d, j1 = j0 + j;
          } else if (d < d2) {
            d2 = d;
          }
          if (d < nearest_to_b[j0 + j]) nearest_to_b[j0 + j] = d, nearest_to_b_index[j0 + j] = i0 + i;
        }
        first[i0 + i] = d1, second[i0 + i] = d2, first_index[i0 + i] = j1;
      }
    }
  }
  const float ratio2 = static_cast<float>(ratio * ratio);  // distances are squared
  for (int i = 0; i < a.rows; ++i) {
    const int j = first_index[i];
    if (j < 0 || !(first[i] < ratio2 * second[i])) continue;
    if (mutual && nearest_to_b_index[j] != i) continue;
    matches.push_back({i, j});
  }
  return matches;
}

std::vector<FeatureMatch> match_features(const FrameFeatures& a, const FrameFeatures& b, double ratio,
                                         bool mutual) {
  return match_descriptors(root_sift(a.descriptors), root_sift(b.descriptors), ratio, mutual);
}

std::vector<bool> fundamental_inliers(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                                      double threshold_px, cv::Mat* fundamental) {
  std::vector<bool> inliers(a.size(), false);
  if (a.size() < 8 || a.size() != b.size()) return inliers;
  cv::Mat mask;
  cv::Mat f = cv::findFundamentalMat(a, b, cv::FM_RANSAC, threshold_px, 0.9999, mask);
  if (f.empty() || f.rows != 3) return inliers;
  if (fundamental) *fundamental = f.rowRange(0, 3).clone();
  for (std::size_t i = 0; i < a.size(); ++i) inliers[i] = mask.at<unsigned char>(static_cast<int>(i)) != 0;
  return inliers;
}

}  // namespace pg
