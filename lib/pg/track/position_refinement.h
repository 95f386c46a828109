#pragma once
// Sub-pixel refinement of a track's observations by patch alignment. A SIFT keypoint is localised to
// a few tenths of a pixel, independently in every frame; once a track is known, each of its
// observations can instead be placed where the image around it best matches the image around one
// reference observation of the same track (after Lindenberger et al. 2021, "Pixel-Perfect
// Structure-from-Motion", here with image intensities rather than learned features). Every
// observation then marks the same surface point, and the bundle adjustment sees residuals of the
// alignment's accuracy (hundredths of a pixel on textured patches) rather than the detector's.
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

#include "pg/track/features.h"

namespace pg {

struct PositionRefinementOptions {
  // The patch is (2 * half_window + 1) pixels square; 0: from the image size (5 up to 1100 pixels,
  // 14 at 3072, at most 16).
  int half_window = 0;
  int max_iterations = 20;    // Gauss-Newton steps per observation
  double max_shift_px = 2.0;  // a refinement moving a point further than this is refused
  // Refused below this zero-mean normalised correlation between the aligned patches.
  double min_correlation = 0.8;
};

struct PositionRefinementStats {
  int refined = 0;           // observations moved to the aligned position
  int refused = 0;           // observations left where the detector put them
  double mean_shift_px = 0;  // over the refined ones
};

// A track as the nodes it joins: (frame, index into that frame's point list).
using NodeTrack = std::vector<std::pair<int, int>>;

// Moves points[f][i] of every track but its reference observation (the middle one in frame order) to
// where an affine patch alignment (with gain and offset) onto the reference lands, when the
// alignment converges within max_shift_px and correlates at least min_correlation. `images` are the
// frames' 8-bit grey images (the points' pixel grid); `shapes` parallels `points` and seeds each
// alignment's rotation and scale. A node must belong to at most one track. Deterministic, parallel
// over tracks.
PositionRefinementStats refine_track_positions(const std::vector<cv::Mat>& images,
                                               std::vector<std::vector<cv::Point2f>>& points,
                                               const std::vector<std::vector<PointShape>>& shapes,
                                               const std::vector<NodeTrack>& tracks,
                                               const PositionRefinementOptions& options = {});

// The same with the frames streamed instead of held: `load(f)` returns frame f's image. A first pass
// over the frames takes every track's reference patch, a second aligns the other observations onto
// them; each pass loads a frame at most once, and at most `frames_at_once` at a time (at least one).
// The results are the same as above.
PositionRefinementStats refine_track_positions(int frame_count, const std::function<cv::Mat(int)>& load,
                                               int frames_at_once,
                                               std::vector<std::vector<cv::Point2f>>& points,
                                               const std::vector<std::vector<PointShape>>& shapes,
                                               const std::vector<NodeTrack>& tracks,
                                               const PositionRefinementOptions& options = {});

}  // namespace pg
