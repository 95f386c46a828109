#include "pg/track/klt.h"

#include <cstdint>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "pg/track/features.h"

namespace pg {

namespace {

// New corners away from the points already alive.
std::vector<cv::Point2f> detect_corners(const cv::Mat& gray8, const cv::Mat& mask,
                                        const std::vector<KltPoint>& alive, int count,
                                        const KltOptions& options) {
  if (count <= 0) return {};
  cv::Mat free_mask = mask.empty() ? cv::Mat(gray8.size(), CV_8U, cv::Scalar(255)) : mask.clone();
  for (const KltPoint& p : alive) cv::circle(free_mask, p.position, options.min_distance, cv::Scalar(0), -1);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray8, corners, count, options.quality, options.min_distance, free_mask, 3);
  if (!corners.empty())
    cv::cornerSubPix(gray8, corners, cv::Size(4, 4), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 20, 0.01));
  return corners;
}

}  // namespace

std::vector<std::vector<KltPoint>> track_klt(const std::vector<cv::Mat>& gray8,
                                             const std::vector<cv::Mat>& masks, const KltOptions& options,
                                             std::vector<int>* continued) {
  return track_klt(
      static_cast<int>(gray8.size()),
      [&](int f) {
        return KltFrame{gray8[f], std::size_t(f) < masks.size() ? masks[f] : cv::Mat()};
      },
      options, continued);
}

std::vector<std::vector<KltPoint>> track_klt(int frame_count, const std::function<KltFrame(int)>& load,
                                             const KltOptions& options, std::vector<int>* continued) {
  std::vector<std::vector<KltPoint>> frames(frame_count);
  if (continued) continued->assign(frame_count, 0);
  if (frame_count == 0) return frames;
  KltFrame previous = load(0);
  int next_id = 0;
  for (const cv::Point2f& c : detect_corners(previous.gray8, previous.mask, {}, options.max_corners, options))
    frames[0].push_back({next_id++, c});
  const cv::Size window(options.window, options.window);
  const cv::TermCriteria criteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 30, 0.01);
  for (int f = 1; f < frame_count; ++f) {
    const KltFrame current = load(f);
    const cv::Mat& gray = current.gray8;
    const std::vector<KltPoint>& prev = frames[f - 1];
    std::vector<cv::Point2f> from, to, back;
    for (const KltPoint& p : prev) from.push_back(p.position);
    std::vector<KltPoint> alive;
    if (!from.empty()) {
      std::vector<unsigned char> status, status_back;
      std::vector<float> error;
      cv::calcOpticalFlowPyrLK(previous.gray8, gray, from, to, status, error, window, options.levels,
                               criteria);
      back = from;
      cv::calcOpticalFlowPyrLK(gray, previous.gray8, to, back, status_back, error, window, options.levels,
                               criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
      std::vector<cv::Point2f> a, b;
      std::vector<int> index;
      const cv::Mat& mask = current.mask;
      for (std::size_t i = 0; i < from.size(); ++i) {
        if (!status[i] || !status_back[i]) continue;
        const cv::Point2f d = back[i] - from[i];
        if (d.dot(d) > options.forward_backward_px * options.forward_backward_px) continue;
        const cv::Point2f& q = to[i];
        if (q.x < 0 || q.y < 0 || q.x > gray.cols - 1 || q.y > gray.rows - 1) continue;
        if (!mask.empty() && mask.at<unsigned char>(cvRound(q.y), cvRound(q.x)) == 0) continue;
        a.push_back(from[i]);
        b.push_back(q);
        index.push_back(static_cast<int>(i));
      }
      const std::vector<bool> inliers = fundamental_inliers(a, b, options.ransac_px);
      for (std::size_t k = 0; k < index.size(); ++k)
        if (inliers[k]) alive.push_back({prev[index[k]].track, b[k]});
    }
    if (continued) (*continued)[f] = static_cast<int>(alive.size());
    if (options.redetect_every_frame) {
      std::vector<KltPoint> fresh_alive;
      std::vector<cv::Point2f> corners = detect_corners(gray, current.mask, {}, options.max_corners, options);
      std::vector<bool> used(corners.size(), false);
      // Snap each tracked point to the nearest fresh corner within snap_px.
      for (KltPoint& p : alive) {
        int best = -1;
        double best_d2 = options.snap_px * options.snap_px;
        for (std::size_t c = 0; c < corners.size(); ++c) {
          const cv::Point2f d = corners[c] - p.position;
          if (!used[c] && d.dot(d) <= best_d2) best_d2 = d.dot(d), best = static_cast<int>(c);
        }
        if (best >= 0) {
          used[best] = true;
          p.position = corners[best];
        }
        fresh_alive.push_back(p);
      }
      for (std::size_t c = 0; c < corners.size(); ++c) {
        if (used[c] || static_cast<int>(fresh_alive.size()) >= options.max_corners) continue;
        bool near = false;
        for (const KltPoint& p : alive) {
          const cv::Point2f d = corners[c] - p.position;
          if (d.dot(d) < options.min_distance * options.min_distance) near = true;
          if (near) break;
        }
        if (!near) fresh_alive.push_back({next_id++, corners[c]});
      }
      alive = std::move(fresh_alive);
    } else if (alive.size() < static_cast<std::size_t>(options.max_corners * 0.8)) {
      const int missing = options.max_corners - static_cast<int>(alive.size());
      for (const cv::Point2f& c : detect_corners(gray, current.mask, alive, missing, options))
        alive.push_back({next_id++, c});
    }
    frames[f] = std::move(alive);
    previous = current;
  }
  return frames;
}

std::uint64_t klt_tracking_bytes(cv::Size size) {
  // The peak is the corner detector's: OpenCV's minimum-eigenvalue image, its derivative and
  // covariance images (float), and the dilated copy goodFeaturesToTrack compares against, about 24.6
  // bytes a pixel measured at 1600x1200 (45 MiB); Lucas-Kanade's pyramids take less.
  constexpr std::uint64_t bytes_per_pixel = 26;
  return bytes_per_pixel * std::uint64_t(size.area());
}

}  // namespace pg
