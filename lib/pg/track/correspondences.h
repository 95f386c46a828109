#pragma once
// Correspondences across an ordered sequence: features, pairwise matching between neighbouring frames
// and between non-neighbouring frames that overlap (so a ring closes), robust verification, and the
// merge of pairwise matches into multi-frame tracks.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pg/track/klt.h"
#include "pg/track/position_refinement.h"
#include "pg/track/tracks.h"

namespace pg {

enum class CorrespondenceMethod {
  sift,        // SIFT (RootSIFT) descriptors, ratio test, mutual check
  klt,         // pyramidal Lucas-Kanade tracks with forward-backward check, replenished as they die
  shi_tomasi,  // Shi-Tomasi corners detected in every frame and tracked (re-anchored) frame to frame
};
std::string to_string(CorrespondenceMethod method);
CorrespondenceMethod correspondence_method_from_string(const std::string& name);  // throws UsageError

struct CorrespondenceOptions {
  CorrespondenceMethod method = CorrespondenceMethod::sift;
  double downscale = 1;       // features are found on images shrunk by this factor (>= 1)
  int max_features = 8000;    // SIFT features kept per frame, strongest first (half in KLT modes)
  double ratio = 0.8;         // Lowe's ratio test
  int sequential_window = 3;  // each frame is matched with the next `sequential_window` frames
  // Non-neighbouring pairs: each frame is probed against every frame outside the window with its
  // strongest features; the best `loop_candidates` overlapping frames are matched in full.
  bool loop_matching = true;
  int loop_candidates = 3;
  int loop_probe_features = 400;
  int min_loop_probe_matches = 15;
  double verify_px = 2.0;     // fundamental-matrix inlier threshold, in working-image pixels
  int min_pair_inliers = 20;  // a pair with fewer verified matches contributes none
  // Three-view consistency of merged tracks (enforce_track_consistency), at this many times verify_px.
  bool track_consistency = true;
  double consistency_factor = 2.0;
  // Sub-pixel alignment of each track's observations onto one of them (refine_track_positions).
  bool refine_positions = true;
  PositionRefinementOptions refinement;
  KltOptions klt;
  // KLT/Shi-Tomasi: consecutive frames joined by fewer tracks are matched by SIFT as well.
  int klt_min_continued = 150;
  // Bytes build_correspondences may hold (a --max-memory budget); 0: none given, and the memory the
  // system has available bounds it instead. Frames are decoded and SIFT detections run (each
  // sift_detection_bytes, about 250 bytes a working pixel) at most as many at a time as fit beside the
  // working images held, and at least one. When those and one detection would take more than half the
  // budget, the working images are not kept: SIFT decodes them again for the position refinement,
  // and KLT also streams them through the tracker two at a time. The results do not depend on it.
  std::uint64_t memory_budget = 0;
};

struct SequenceFrame {
  std::string id;
  std::filesystem::path image;
  std::filesystem::path mask;  // empty: none; otherwise nonzero pixels are ignored
};

struct VerifiedPair {
  int a = 0, b = 0;
  int matches = 0;    // after the ratio test and mutual check
  int inliers = 0;    // after the fundamental-matrix check
  bool loop = false;  // found by loop probing (not a sequential neighbour)
  // x_b^T F x_a = 0 in full-resolution pixels; all zero when the pair was not accepted.
  cv::Matx33d fundamental = cv::Matx33d::zeros();
};

struct CorrespondenceResult {
  TrackSet tracks;
  std::vector<VerifiedPair> pairs;     // every pair matched, accepted or not
  int inconsistent_observations = 0;   // removed by the three-view consistency check
  PositionRefinementStats refinement;  // zero when refinement is off
};

// The least memory build_correspondences needs for `frames`, from their file headers: every frame's
// features, and the largest of one frame being decoded, one SIFT detection with its image, and (KLT
// modes) one tracking step with its two frames. Runs with a frame whose header pg cannot read
// (peek_image_size) also hold every working image; such a frame is itself left out. Throws
// InputError for a missing or corrupt file.
std::uint64_t correspondence_memory_bytes(const std::vector<SequenceFrame>& frames,
                                          const CorrespondenceOptions& options);

// Each frame's image size as its file header gives it, or nullopt for a format without a size in its
// header (PNG, JPEG, OpenEXR and Radiance have one). Reads headers only, so a long sequence is checked
// in moments: throws InputError for a missing or corrupt file, or for a mask whose header gives
// another size than its image's (build_correspondences checks the rest once decoded).
std::vector<std::optional<cv::Size>> sequence_image_sizes(const std::vector<SequenceFrame>& frames);

// Throws InputError for unreadable images or masks of a different size than their image,
// UsageError for fewer than 2 frames.
CorrespondenceResult build_correspondences(const std::vector<SequenceFrame>& frames,
                                           const CorrespondenceOptions& options);

// Union-find merge of pairwise links between per-frame point lists into tracks. `frame_points[f]` holds
// frame f's points in full-resolution pixels; links join (frame, index) nodes. A component that holds
// several points of one frame keeps the first of them when they coincide (within 0.5 px: one keypoint
// detected twice, with two orientations) and drops that frame's observations otherwise (ambiguous);
// components left with fewer than two observations are dropped.
struct PointLink {
  int frame_a, index_a, frame_b, index_b;
};
std::vector<Track> merge_links_into_tracks(const std::vector<std::vector<cv::Point2f>>& frame_points,
                                           const std::vector<PointLink>& links);

// merge_links_into_tracks in two steps: the components as (frame, index) nodes, then the tracks of those
// nodes at `frame_points`' positions.
std::vector<NodeTrack> link_components(const std::vector<std::vector<cv::Point2f>>& frame_points,
                                       const std::vector<PointLink>& links);
std::vector<Track> tracks_of_components(const std::vector<std::vector<cv::Point2f>>& frame_points,
                                        const std::vector<NodeTrack>& components);

// Three-view consistency. Merging pairwise links can chain links that are each right into a track
// that is wrong (a-b and b-c verified, but a's and c's observations are of different points). Every
// two observations of a track of three or more frames whose frames form an accepted pair are checked
// against that pair's fundamental matrix (Sampson distance up to threshold_px); the observation in
// conflict with the most others is dropped (all of them on a tie), until none conflicts. Tracks left
// with fewer than two observations are dropped. Returns the number of observations removed.
int enforce_track_consistency(std::vector<Track>& tracks, const std::vector<VerifiedPair>& pairs,
                              double threshold_px);

// Sampson distance (pixels) of the correspondence a <-> b under x_b^T F x_a = 0.
double sampson_distance(const cv::Matx33d& fundamental, const cv::Point2d& a, const cv::Point2d& b);

}  // namespace pg
