#include "pg/track/correspondences.h"

#include <tbb/parallel_for.h>
#include <algorithm>
#include <chrono>
#include <map>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"
#include "pg/core/run_report.h"
#include "pg/core/system_memory.h"
#include "pg/image/image_io.h"
#include "pg/track/features.h"

namespace pg {

std::string to_string(CorrespondenceMethod method) {
  switch (method) {
    case CorrespondenceMethod::sift:
      return "sift";
    case CorrespondenceMethod::klt:
      return "klt";
    case CorrespondenceMethod::shi_tomasi:
      return "shi-tomasi";
  }
  return "?";
}

CorrespondenceMethod correspondence_method_from_string(const std::string& name) {
  if (name == "sift") return CorrespondenceMethod::sift;
  if (name == "klt") return CorrespondenceMethod::klt;
  if (name == "shi-tomasi") return CorrespondenceMethod::shi_tomasi;
  throw UsageError(str("unknown matcher '", name, "' (sift, klt or shi-tomasi)"));
}

namespace {

struct WorkingFrame {
  cv::Mat gray8, mask;              // working resolution
  cv::Size full_size;               // the image file's size
  double scale_x = 1, scale_y = 1;  // full / working
  cv::Point2f to_full(const cv::Point2f& p) const {
    return {static_cast<float>((p.x + 0.5) * scale_x - 0.5), static_cast<float>((p.y + 0.5) * scale_y - 0.5)};
  }
  // The same map as a homography, full <- working.
  cv::Matx33d full_from_working() const {
    return {scale_x, 0, 0.5 * scale_x - 0.5, 0, scale_y, 0.5 * scale_y - 0.5, 0, 0, 1};
  }
};

// SIFT features kept per frame: max_features, half of it in KLT modes, where SIFT only bridges weak
// links and closes loops.
int sift_features_kept(const CorrespondenceOptions& options) {
  return options.method == CorrespondenceMethod::sift ? options.max_features : options.max_features / 2;
}

// The size of the working image of a `full`-size image shrunk by `downscale`.
cv::Size working_size(cv::Size full, double downscale) {
  if (downscale <= 1) return full;
  return {std::max(1, static_cast<int>(std::lround(full.width / downscale))),
          std::max(1, static_cast<int>(std::lround(full.height / downscale)))};
}

void require_mask_size(const SequenceFrame& frame, cv::Size mask, cv::Size image) {
  if (mask != image)
    throw InputError(frame.mask, str("mask is ", mask.width, "x", mask.height, " but image ",
                                     frame.image.string(), " is ", image.width, "x", image.height));
}

// The frame's working image, and its mask unless `with_mask` is false.
WorkingFrame load_frame(const SequenceFrame& frame, double downscale, bool with_mask = true) {
  WorkingFrame w;
  cv::Mat gray = read_image(frame.image, ReadMode::gray_float);
  w.full_size = gray.size();
  gray.convertTo(w.gray8, CV_8U, 255.0);
  cv::Mat mask;
  if (with_mask && !frame.mask.empty()) {
    mask = read_image(frame.mask, ReadMode::gray_float);
    require_mask_size(frame, mask.size(), gray.size());
    cv::Mat usable = mask == 0.0f;  // nonzero = ignore, as every pg stage reads a mask
    w.mask = usable;
  }
  if (downscale > 1) {
    const cv::Size size = working_size(gray.size(), downscale);
    cv::Mat small;
    cv::resize(w.gray8, small, size, 0, 0, cv::INTER_AREA);
    w.gray8 = small;
    if (!w.mask.empty()) {
      cv::Mat small_mask;
      cv::resize(w.mask, small_mask, size, 0, 0, cv::INTER_NEAREST);
      w.mask = small_mask;
    }
    w.scale_x = static_cast<double>(gray.cols) / size.width;
    w.scale_y = static_cast<double>(gray.rows) / size.height;
  }
  return w;
}

// What frames cost in memory, from their file headers: what build_correspondences may keep (the 8-bit
// working images and masks, and the most features detect_sift keeps), what load_frame holds while it
// decodes one frame (the file decoded, its float grey and 8-bit copies, and the same for a mask), one
// SIFT detection with the image it searches, and KLT tracking into the frame (decoding it beside the
// frame before, then tracking between the two). For several frames: the sums of what is kept, the
// largest decode, detection and tracking step.
struct FrameMemory {
  std::uint64_t images = 0, features = 0, load = 0, detection = 0, tracking = 0;
  int unknown = 0;  // frames whose size no header told (left out of the rest)
};

FrameMemory frame_memory(const SequenceFrame& frame, const CorrespondenceOptions& options) {
  const std::optional<cv::Size> full = peek_image_size(frame.image);
  if (!full) return {.unknown = 1};
  const int planes = frame.mask.empty() ? 1 : 2;
  const cv::Size working = working_size(*full, options.downscale);
  const std::uint64_t decoded = decoded_image_bytes_per_pixel(frame.image) + sizeof(float) + 1;
  FrameMemory m;
  m.images = std::uint64_t(working.area()) * planes;
  m.features = std::uint64_t(sift_features_kept(options)) * sift_feature_bytes;
  m.load = std::uint64_t(full->area()) * decoded * planes;
  m.detection = sift_detection_bytes(working) + m.images;
  // Streamed, a frame is decoded beside the one before, then the two are tracked.
  m.tracking = std::max(m.images + m.load, 2 * m.images + klt_tracking_bytes(working));
  return m;
}

FrameMemory frames_memory(const std::vector<SequenceFrame>& frames, const CorrespondenceOptions& options) {
  FrameMemory total;
  for (const SequenceFrame& frame : frames) {
    const FrameMemory m = frame_memory(frame, options);
    total.images += m.images;
    total.features += m.features;
    total.load = std::max(total.load, m.load);
    total.detection = std::max(total.detection, m.detection);
    total.tracking = std::max(total.tracking, m.tracking);
    total.unknown += m.unknown;
  }
  return total;
}

// How many tasks of `task_bytes` fit in what `budget` leaves beside `held`: at least one, at most `n`
// (every one when the budget is unknown, 0).
int tasks_that_fit(std::uint64_t budget, std::uint64_t held, std::uint64_t task_bytes, int n) {
  if (budget == 0 || task_bytes == 0) return n;
  const std::uint64_t free = budget > held ? budget - held : 0;
  return static_cast<int>(std::clamp<std::uint64_t>(free / task_bytes, 1, std::max(1, n)));
}

struct SiftMatcher {
  const std::vector<WorkingFrame>& work;
  const std::vector<FrameFeatures>& features;
  const CorrespondenceOptions& options;
  std::vector<PointLink>& links;
  std::vector<int> node_offset;  // SIFT features of frame f follow node_offset[f] other points
  std::vector<VerifiedPair>& pairs;

  // Pairs are matched in parallel; their links are appended in pair order (deterministic).
  void match_all(const std::vector<std::pair<int, int>>& list, bool loop) {
    std::vector<std::vector<PointLink>> pair_links(list.size());
    std::vector<VerifiedPair> pair_info(list.size());
    tbb::parallel_for(std::size_t(0), list.size(), [&](std::size_t i) {
      pair_info[i] = match(list[i].first, list[i].second, loop, pair_links[i]);
    });
    for (std::size_t i = 0; i < list.size(); ++i) {
      pairs.push_back(pair_info[i]);
      links.insert(links.end(), pair_links[i].begin(), pair_links[i].end());
    }
  }

  VerifiedPair match(int a, int b, bool loop, std::vector<PointLink>& out) const {
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<FeatureMatch> m = match_features(features[a], features[b], options.ratio, true);
    std::vector<cv::Point2f> pa, pb;
    for (const FeatureMatch& x : m) {
      pa.push_back(features[a].points[x.a]);
      pb.push_back(features[b].points[x.b]);
    }
    const auto t1 = std::chrono::steady_clock::now();
    cv::Mat fundamental;
    const std::vector<bool> inliers = fundamental_inliers(pa, pb, options.verify_px, &fundamental);
    const int count = static_cast<int>(std::count(inliers.begin(), inliers.end(), true));
    log::debug("match ", a, "-", b, ": ", m.size(), " matches, ", count, " inliers; ",
               std::chrono::duration<double>(t1 - t0).count(), " s matching, ",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count(), " s verifying");
    VerifiedPair info{a, b, static_cast<int>(m.size()), count, loop};
    if (count < options.min_pair_inliers) return info;
    // x_b^T F x_a = 0 in working pixels; in full pixels F' = T_b^-T F T_a^-1.
    info.fundamental =
        work[b].full_from_working().inv().t() * cv::Matx33d(fundamental) * work[a].full_from_working().inv();
    for (std::size_t k = 0; k < m.size(); ++k)
      if (inliers[k]) out.push_back({a, node_offset[a] + m[k].a, b, node_offset[b] + m[k].b});
    return info;
  }
};

// Pairs outside the sequential window whose strongest features match well enough.
std::vector<std::pair<int, int>> loop_pairs(const std::vector<FrameFeatures>& features,
                                            const CorrespondenceOptions& options) {
  const int n = static_cast<int>(features.size());
  std::vector<cv::Mat> probes;  // RootSIFT of each frame's strongest features, made once
  for (const FrameFeatures& f : features)
    probes.push_back(root_sift(strongest_features(f, options.loop_probe_features).descriptors));
  std::vector<std::pair<int, int>> probed;
  for (int a = 0; a < n; ++a)
    for (int b = a + options.sequential_window + 1; b < n; ++b) probed.push_back({a, b});
  std::vector<int> counts(probed.size());
  tbb::parallel_for(std::size_t(0), probed.size(), [&](std::size_t i) {
    const auto [a, b] = probed[i];
    counts[i] = static_cast<int>(match_descriptors(probes[a], probes[b], options.ratio, true).size());
  });
  std::vector<std::vector<std::pair<int, int>>> score(n);  // (count, other)
  for (std::size_t i = 0; i < probed.size(); ++i) {
    if (counts[i] < options.min_loop_probe_matches) continue;
    const auto [a, b] = probed[i];
    score[a].push_back({counts[i], b});
    score[b].push_back({counts[i], a});
  }
  std::vector<std::pair<int, int>> chosen;
  for (int a = 0; a < n; ++a) {
    std::sort(score[a].rbegin(), score[a].rend());
    for (int k = 0; k < std::min<int>(options.loop_candidates, static_cast<int>(score[a].size())); ++k)
      chosen.push_back({std::min(a, score[a][k].second), std::max(a, score[a][k].second)});
  }
  std::sort(chosen.begin(), chosen.end());
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  return chosen;
}

}  // namespace

std::vector<NodeTrack> link_components(const std::vector<std::vector<cv::Point2f>>& frame_points,
                                       const std::vector<PointLink>& links) {
  constexpr float coincident_px = 0.5f;  // a frame's points this close are one detection
  std::vector<int> offset(frame_points.size() + 1, 0);
  for (std::size_t f = 0; f < frame_points.size(); ++f)
    offset[f + 1] = offset[f] + static_cast<int>(frame_points[f].size());
  std::vector<int> parent(offset.back());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<bool> linked(parent.size(), false);
  for (const PointLink& l : links) {
    const int a = offset[l.frame_a] + l.index_a, b = offset[l.frame_b] + l.index_b;
    linked[a] = linked[b] = true;
    const int ra = find(a), rb = find(b);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  // Group nodes by root, in frame order (nodes are numbered frame by frame).
  std::vector<int> track_of_root(parent.size(), -1);
  std::vector<NodeTrack> members;
  for (std::size_t f = 0; f < frame_points.size(); ++f)
    for (int i = 0; i < static_cast<int>(frame_points[f].size()); ++i) {
      const int node = offset[f] + i;
      if (!linked[node]) continue;
      const int root = find(node);
      if (track_of_root[root] < 0) {
        track_of_root[root] = static_cast<int>(members.size());
        members.emplace_back();
      }
      members[track_of_root[root]].push_back({static_cast<int>(f), i});
    }
  // A frame's nodes in one component: one observation when they coincide (SIFT gives a keypoint with
  // two dominant orientations twice, at one place, and neighbours may match either), none otherwise.
  std::vector<NodeTrack> tracks;
  for (const NodeTrack& m : members) {
    NodeTrack t;
    for (std::size_t first = 0, end = 0; first < m.size(); first = end) {
      const auto [frame, index] = m[first];
      bool coincide = true;
      for (end = first + 1; end < m.size() && m[end].first == frame; ++end) {
        const cv::Point2f d = frame_points[frame][m[end].second] - frame_points[frame][index];
        coincide = coincide && d.dot(d) <= coincident_px * coincident_px;
      }
      if (coincide) t.push_back(m[first]);  // the first: detect_sift stores the strongest first
    }
    if (t.size() >= 2) tracks.push_back(std::move(t));
  }
  return tracks;
}

std::vector<Track> tracks_of_components(const std::vector<std::vector<cv::Point2f>>& frame_points,
                                        const std::vector<NodeTrack>& components) {
  std::vector<Track> tracks;
  for (const NodeTrack& nodes : components) {
    Track& t = tracks.emplace_back();
    for (const auto& [frame, index] : nodes)
      t.observations.push_back({frame, frame_points[frame][index].x, frame_points[frame][index].y});
  }
  return tracks;
}

std::vector<Track> merge_links_into_tracks(const std::vector<std::vector<cv::Point2f>>& frame_points,
                                           const std::vector<PointLink>& links) {
  return tracks_of_components(frame_points, link_components(frame_points, links));
}

double sampson_distance(const cv::Matx33d& fundamental, const cv::Point2d& a, const cv::Point2d& b) {
  const cv::Vec3d xa(a.x, a.y, 1), xb(b.x, b.y, 1);
  const cv::Vec3d fa = fundamental * xa, fb = fundamental.t() * xb;
  const double residual = xb.dot(fa);
  const double norm = fa[0] * fa[0] + fa[1] * fa[1] + fb[0] * fb[0] + fb[1] * fb[1];
  return norm > 0 ? std::abs(residual) / std::sqrt(norm) : 0.0;
}

int enforce_track_consistency(std::vector<Track>& tracks, const std::vector<VerifiedPair>& pairs,
                              double threshold_px) {
  std::map<std::pair<int, int>, const cv::Matx33d*> accepted;
  for (const VerifiedPair& p : pairs)
    if (cv::norm(p.fundamental) > 0) accepted[{p.a, p.b}] = &p.fundamental;
  int removed = 0;
  std::vector<Track> kept;
  kept.reserve(tracks.size());
  for (Track& track : tracks) {
    const std::vector<TrackObservation>& obs = track.observations;
    const std::size_t n = obs.size();
    if (n >= 3) {
      std::vector<std::vector<int>> conflicts(n);
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
          const bool forward = obs[i].frame < obs[j].frame;
          const TrackObservation& a = forward ? obs[i] : obs[j];
          const TrackObservation& b = forward ? obs[j] : obs[i];
          const auto it = accepted.find({a.frame, b.frame});
          if (it == accepted.end()) continue;
          if (sampson_distance(*it->second, {a.x, a.y}, {b.x, b.y}) > threshold_px) {
            conflicts[i].push_back(static_cast<int>(j));
            conflicts[j].push_back(static_cast<int>(i));
          }
        }
      std::vector<bool> alive(n, true);
      while (true) {
        std::vector<int> count(n, 0);
        int most = 0;
        for (std::size_t i = 0; i < n; ++i) {
          if (!alive[i]) continue;
          for (int j : conflicts[i]) count[i] += alive[j] ? 1 : 0;
          most = std::max(most, count[i]);
        }
        if (most == 0) break;
        for (std::size_t i = 0; i < n; ++i)
          if (alive[i] && count[i] == most) alive[i] = false, ++removed;
      }
      std::vector<TrackObservation> consistent;
      for (std::size_t i = 0; i < n; ++i)
        if (alive[i]) consistent.push_back(obs[i]);
      if (consistent.size() < n) {
        // The removed observations count as removed; a track that falls below two loses the rest too.
        if (consistent.size() < 2) removed += static_cast<int>(consistent.size());
        track.observations = std::move(consistent);
      }
    }
    if (track.observations.size() >= 2) kept.push_back(std::move(track));
  }
  tracks = std::move(kept);
  return removed;
}

std::vector<std::optional<cv::Size>> sequence_image_sizes(const std::vector<SequenceFrame>& frames) {
  std::vector<std::optional<cv::Size>> sizes;
  for (const SequenceFrame& frame : frames) {
    sizes.push_back(peek_image_size(frame.image));
    if (frame.mask.empty()) continue;
    const std::optional<cv::Size> mask = peek_image_size(frame.mask);
    if (mask && sizes.back()) require_mask_size(frame, *mask, *sizes.back());
  }
  return sizes;
}

std::uint64_t correspondence_memory_bytes(const std::vector<SequenceFrame>& frames,
                                          const CorrespondenceOptions& options) {
  const FrameMemory m = frames_memory(frames, options);
  // The working images need not be kept (see build_correspondences) unless a frame's size is unknown.
  const bool klt = options.method != CorrespondenceMethod::sift;
  return (m.unknown == 0 ? 0 : m.images) + m.features + std::max({m.load, m.detection, klt ? m.tracking : 0});
}

CorrespondenceResult build_correspondences(const std::vector<SequenceFrame>& frames,
                                           const CorrespondenceOptions& options) {
  if (frames.size() < 2) throw UsageError(str("tracking needs at least 2 images, got ", frames.size()));
  if (options.downscale < 1) throw UsageError("downscale must be at least 1");
  const int n = static_cast<int>(frames.size());
  const std::uint64_t budget = options.memory_budget ? options.memory_budget : available_memory_bytes();
  const FrameMemory planned = frames_memory(frames, options);
  const int threads = std::min(n, thread_count());
  const bool klt = options.method != CorrespondenceMethod::sift;
  // KLT follows points through the frames in order. It keeps every working image when they fit in
  // half the budget beside the features and its largest step, as SIFT keeps them below; then they
  // are decoded up front, in parallel. Otherwise it streams them, two at a time, and they are
  // decoded again where they are needed next. A frame whose header pg cannot read has no size to
  // plan with: then every frame is decoded up front. Otherwise SIFT decodes each where its features
  // are found.
  const bool stream_klt =
      klt && planned.unknown == 0 && budget > 0 &&
      planned.images + planned.features + std::max({planned.load, planned.detection, planned.tracking}) >
          budget / 2;
  const bool decode_up_front = (klt && !stream_klt) || planned.unknown > 0;
  std::vector<WorkingFrame> work(n);
  if (decode_up_front)
    parallel_for_bounded(n, tasks_that_fit(budget, planned.images + planned.features, planned.load, threads),
                         [&](int f) { work[f] = load_frame(frames[f], options.downscale); });
  bool images_held = !stream_klt;  // the working images stay in memory for the position refinement

  CorrespondenceResult result;
  result.tracks.method = to_string(options.method);

  // Per-frame point lists (working pixels): KLT points first, then SIFT features.
  std::vector<std::vector<cv::Point2f>> points(n);
  std::vector<std::vector<PointShape>> shapes(n);  // parallel to points; KLT points have none
  std::vector<PointLink> links;
  std::vector<int> continued(n, 0);
  if (klt) {
    ScopedTimer timer("klt tracking");
    KltOptions ko = options.klt;
    ko.redetect_every_frame = options.method == CorrespondenceMethod::shi_tomasi;
    RunReport::global().set_metric("klt_frames_streamed", stream_klt);
    if (stream_klt) log::info("klt: streaming the frames (memory budget)");
    const auto tracked = track_klt(
        n,
        [&](int f) {
          if (!stream_klt) return KltFrame{work[f].gray8, work[f].mask};
          work[f] = load_frame(frames[f], options.downscale);
          const KltFrame frame{work[f].gray8, work[f].mask};
          work[f].gray8.release(), work[f].mask.release();  // the frame's size and scale stay
          return frame;
        },
        ko, &continued);
    std::vector<std::pair<int, int>> last_seen;  // track id -> (frame, index)
    for (int f = 0; f < n; ++f)
      for (const KltPoint& p : tracked[f]) {
        const int index = static_cast<int>(points[f].size());
        points[f].push_back(p.position);
        shapes[f].emplace_back();
        if (p.track >= static_cast<int>(last_seen.size())) last_seen.resize(p.track + 1, {-1, -1});
        const auto [pf, pi] = last_seen[p.track];
        if (pf >= 0) links.push_back({pf, pi, f, index});
        last_seen[p.track] = {f, index};
      }
    for (int f = 1; f < n; ++f)
      log::debug("klt: ", continued[f], " tracks continue into frame ", frames[f].id);
  }

  std::vector<std::pair<int, int>> sift_pairs;
  if (!klt) {
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b <= std::min(n - 1, a + options.sequential_window); ++b)
        sift_pairs.push_back({a, b});
  } else {
    for (int f = 1; f < n; ++f)
      if (continued[f] < options.klt_min_continued) sift_pairs.push_back({f - 1, f});
  }
  const bool need_sift = !sift_pairs.empty() || options.loop_matching;
  if (need_sift) {
    std::vector<FrameFeatures> features(n);
    std::vector<int> offset(n);
    std::optional<ScopedTimer> timer(std::in_place, "sift features");
    // Detections at once beside what is held: every frame's features, and their working images
    // unless those are dropped after detection. They are dropped when keeping them and running the
    // detections would take more than half the budget (the rest is for matching and mapping); then
    // they are decoded again for the position refinement. Frames decoded up front are measured.
    // (Matching then takes two RootSIFT copies a pair matched at once, 8 MiB at 8000 features, out
    // of the half left.)
    std::uint64_t images = planned.images, task = std::max(planned.load, planned.detection);
    if (decode_up_front) {
      images = task = 0;
      for (const WorkingFrame& w : work) {
        images += w.gray8.total() + w.mask.total();
        task = std::max(task, sift_detection_bytes(w.gray8.size()));
      }
    }
    const std::uint64_t features_held = std::uint64_t(n) * sift_features_kept(options) * sift_feature_bytes;
    int at_once = tasks_that_fit(budget, images + features_held, task, threads);
    images_held = !stream_klt &&
                  (decode_up_front || budget == 0 || images + features_held + at_once * task <= budget / 2);
    if (!images_held) at_once = tasks_that_fit(budget, features_held, task, threads);
    RunReport::global().set_metric("sift_detections_at_once", at_once);
    if (at_once < threads)
      log::info("sift: memory allows ", at_once, " detection", at_once > 1 ? "s" : "", " at a time (",
                task >> 20, " MiB each, budget ", budget >> 20, " MiB)");
    parallel_for_bounded(n, at_once, [&](int f) {
      if (!decode_up_front) work[f] = load_frame(frames[f], options.downscale);
      features[f] = detect_sift(work[f].gray8, work[f].mask, sift_features_kept(options));
      work[f].mask.release();  // only detection reads masks
      if (!images_held) work[f].gray8.release();
    });
    for (int f = 0; f < n; ++f) {
      offset[f] = static_cast<int>(points[f].size());
      points[f].insert(points[f].end(), features[f].points.begin(), features[f].points.end());
      shapes[f].insert(shapes[f].end(), features[f].shapes.begin(), features[f].shapes.end());
      log::debug("sift: ", features[f].points.size(), " features in ", frames[f].id);
    }
    timer.emplace("sift matching");
    SiftMatcher matcher{work, features, options, links, offset, result.pairs};
    matcher.match_all(sift_pairs, false);
    if (options.loop_matching) {
      // In KLT modes, every pair beyond consecutive frames is a loop candidate.
      CorrespondenceOptions probe = options;
      if (klt) probe.sequential_window = 1;
      matcher.match_all(loop_pairs(features, probe), true);
    }
  }

  for (int f = 0; f < n; ++f)
    result.tracks.frames.push_back(
        {frames[f].id, frames[f].image.string(), work[f].full_size.width, work[f].full_size.height});

  // Refinement moves points, never links: the components found here are the tracks built below.
  const std::vector<NodeTrack> components = link_components(points, links);
  if (options.refine_positions) {
    const ScopedTimer timer("position refinement");
    RunReport::global().set_metric("images_held", images_held);
    if (!images_held) log::info("position refinement: decoding the images again (memory budget)");
    const auto gray = [&](int f) {
      return images_held ? work[f].gray8 : load_frame(frames[f], options.downscale, false).gray8;
    };
    const int frames_at_once =
        images_held ? n : tasks_that_fit(budget, planned.features, planned.load + planned.images, threads);
    const PositionRefinementStats& stats = result.refinement =
        refine_track_positions(n, gray, frames_at_once, points, shapes, components, options.refinement);
    log::debug("position refinement: ", stats.refined, " observations moved (mean ", stats.mean_shift_px,
               " px), ", stats.refused, " left");
  }

  // To full-resolution pixels, then tracks.
  for (int f = 0; f < n; ++f)
    for (cv::Point2f& p : points[f]) p = work[f].to_full(p);
  result.tracks.tracks = tracks_of_components(points, components);
  if (options.track_consistency) {
    result.inconsistent_observations =
        enforce_track_consistency(result.tracks.tracks, result.pairs,
                                  options.consistency_factor * options.verify_px * options.downscale);
    log::debug("three-view check: ", result.inconsistent_observations, " observations removed");
  }
  if (klt && options.loop_matching) result.tracks.method += "+sift";
  return result;
}

}  // namespace pg
