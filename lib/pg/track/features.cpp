#include "pg/track/features.h"

#include <opencv2/flann/random.h>
#include <algorithm>
#include <mutex>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>

namespace pg {

namespace {

// RootSIFT (Arandjelovic and Zisserman 2012): L1-normalise, then square root; Euclidean distance on
// the result compares descriptors by the Hellinger kernel, which matches more reliably than L2.
void to_root_sift(cv::Mat& descriptors) {
  for (int r = 0; r < descriptors.rows; ++r) {
    float* row = descriptors.ptr<float>(r);
    float sum = 0;
    for (int c = 0; c < descriptors.cols; ++c) sum += std::abs(row[c]);
    const float inv = sum > 0 ? 1.0f / sum : 0.0f;
    for (int c = 0; c < descriptors.cols; ++c) row[c] = std::sqrt(std::abs(row[c]) * inv);
  }
}

}  // namespace

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
                         CV_32F);
  for (std::size_t k = 0; k < order.size(); ++k) {
    // OpenCV's SIFT doubles the image first (INTER_LINEAR, pixel centres at i / 2 - 0.25) but halves
    // keypoint coordinates without the offset: every keypoint sits 0.25 px right of and below its place.
    out.points.push_back(keypoints[order[k]].pt - cv::Point2f(0.25f, 0.25f));
    out.shapes.push_back({keypoints[order[k]].size, keypoints[order[k]].angle});
    out.responses.push_back(keypoints[order[k]].response);
    descriptors.row(order[k]).copyTo(out.descriptors.row(static_cast<int>(k)));
  }
  to_root_sift(out.descriptors);
  return out;
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
  std::vector<FeatureMatch> matches;
  if (descriptors_a.rows < 2 || descriptors_b.rows < 2) return matches;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> ab, ba;
  matcher.knnMatch(descriptors_a, descriptors_b, ab, 2);
  std::vector<int> best_ba;
  if (mutual) {
    matcher.knnMatch(descriptors_b, descriptors_a, ba, 1);
    best_ba.assign(descriptors_b.rows, -1);
    for (const auto& m : ba)
      if (!m.empty()) best_ba[m[0].queryIdx] = m[0].trainIdx;
  }
  for (const auto& m : ab) {
    if (m.size() < 2 || m[0].distance >= ratio * m[1].distance) continue;
    if (mutual && best_ba[m[0].trainIdx] != m[0].queryIdx) continue;
    matches.push_back({m[0].queryIdx, m[0].trainIdx});
  }
  return matches;
}

struct DescriptorIndex::Impl {
  cv::Mat data;  // the index keeps a reference to its data
  cv::flann::Index index;
};

DescriptorIndex::DescriptorIndex(const cv::Mat& descriptors, std::uint64_t seed)
    : impl_(new Impl), rows_(descriptors.rows) {
  impl_->data = descriptors.clone();
  if (rows_ < 2) return;
  // The randomised trees draw from the C library's rand(): seeding it per build (under a lock, the
  // state is global) makes every index, hence every match, independent of what ran before. Seed 1
  // keeps the stream every earlier release used.
  const std::uint64_t mixed = (seed - 1) * 0x9e3779b97f4a7c15ull;
  static std::mutex rand_mutex;
  const std::lock_guard lock(rand_mutex);
  cvflann::seed_random(0x9e3779b9u ^ static_cast<unsigned>(mixed ^ (mixed >> 32)));
  impl_->index.build(impl_->data, cv::flann::KDTreeIndexParams(4), cvflann::FLANN_DIST_L2);
}

DescriptorIndex::~DescriptorIndex() {
  delete impl_;
}

void DescriptorIndex::nearest_two(const cv::Mat& queries, cv::Mat& indices,
                                  cv::Mat& squared_distances) const {
  impl_->index.knnSearch(queries, indices, squared_distances, 2, cv::flann::SearchParams(64));
}

std::vector<FeatureMatch> match_indexed(const cv::Mat& descriptors_a, const DescriptorIndex& index_a,
                                        const cv::Mat& descriptors_b, const DescriptorIndex& index_b,
                                        double ratio, bool mutual) {
  std::vector<FeatureMatch> matches;
  if (index_a.size() < 2 || index_b.size() < 2) return matches;
  cv::Mat ab_index, ab_dist, ba_index, ba_dist;
  index_b.nearest_two(descriptors_a, ab_index, ab_dist);
  if (mutual) index_a.nearest_two(descriptors_b, ba_index, ba_dist);
  const float ratio2 = static_cast<float>(ratio * ratio);  // distances are squared
  for (int i = 0; i < descriptors_a.rows; ++i) {
    const int j = ab_index.at<int>(i, 0);
    if (j < 0 || j >= descriptors_b.rows || !(ab_dist.at<float>(i, 0) < ratio2 * ab_dist.at<float>(i, 1)))
      continue;
    if (mutual && ba_index.at<int>(j, 0) != i) continue;
    matches.push_back({i, j});
  }
  return matches;
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
