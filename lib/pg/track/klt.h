#pragma once
// Corner tracking through an ordered sequence with pyramidal Lucas-Kanade, a forward-backward check
// and a RANSAC fundamental-matrix check between consecutive frames.
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

namespace pg {

struct KltOptions {
  int max_corners = 4000;            // corners kept alive per frame
  int min_distance = 8;              // pixels between corners
  double quality = 0.005;            // Shi-Tomasi quality level (fraction of the strongest corner)
  int window = 21;                   // Lucas-Kanade window side
  int levels = 4;                    // pyramid levels above the image
  double forward_backward_px = 0.5;  // largest round-trip error accepted
  double ransac_px = 1.0;            // fundamental-matrix inlier threshold between consecutive frames
  // Shi-Tomasi mode: detect corners afresh in every frame and snap a tracked point to a fresh corner
  // within snap_px (re-anchoring limits drift); KLT mode replenishes only where tracks died.
  bool redetect_every_frame = false;
  double snap_px = 0.5;
};

// One tracked point: its id (shared across the frames it lives in) and position.
struct KltPoint {
  int track = 0;
  cv::Point2f position;
};

// Per frame, the points alive in it. `masks` may be empty or hold one (possibly empty) mask per frame.
// `continued[f]` (f > 0) is the number of tracks carried from frame f - 1 into frame f.
std::vector<std::vector<KltPoint>> track_klt(const std::vector<cv::Mat>& gray8,
                                             const std::vector<cv::Mat>& masks, const KltOptions& options,
                                             std::vector<int>* continued = nullptr);

// One frame as the streaming track_klt takes it: its 8-bit grey image and its mask (may be empty).
struct KltFrame {
  cv::Mat gray8, mask;
};

// The same with the frames streamed instead of held: `load(f)` is called once per frame, in order,
// and at most two frames are held at a time. The results are the same as above.
std::vector<std::vector<KltPoint>> track_klt(int frame_count, const std::function<KltFrame(int)>& load,
                                             const KltOptions& options,
                                             std::vector<int>* continued = nullptr);

// Bytes track_klt holds besides its two frames while it tracks into a `size` frame: the pyramids
// and derivatives Lucas-Kanade builds, and the corner detector's eigenvalue images.
std::uint64_t klt_tracking_bytes(cv::Size size);

}  // namespace pg
