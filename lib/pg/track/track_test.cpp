#include <gtest/gtest.h>

#include <atomic>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <tuple>

#include "pg/camera/camera.h"
#include "pg/core/error.h"
#include "pg/testing/testing.h"
#include "pg/track/correspondences.h"
#include "pg/track/descriptor_dots.h"
#include "pg/track/features.h"
#include "pg/track/tracks.h"

namespace pg {
namespace {

using testing::TempDir;

// Uniform noise blurred to blobs a few pixels across, stretched to the full 8-bit range: texture that
// SIFT and KLT find everywhere.
cv::Mat blurred_noise(cv::Size size, int seed) {
  cv::Mat image(size, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 2.0);
  cv::normalize(image, image, 0, 255, cv::NORM_MINMAX);
  return image;
}

TrackSet small_set() {
  TrackSet set;
  set.method = "sift";
  set.frames = {{"a", "a.png", 640, 480}, {"b", "b.png", 640, 480}, {"c", "c.png", 640, 480}};
  set.tracks = {{{{0, 10.5f, 20.25f}, {1, 11.0f, 21.0f}, {2, 12.0f, 22.0f}}, 0},
                {{{1, 100.0f, 200.0f}, {2, 101.5f, 199.5f}}, -1}};
  return set;
}

TEST(Tracks, WriteReadRoundTrip) {
  TempDir dir;
  write_tracks(dir / "tracks.json", small_set());
  const TrackSet back = read_tracks(dir / "tracks.json");
  ASSERT_EQ(back.frames.size(), 3u);
  EXPECT_EQ(back.frames[1].id, "b");
  EXPECT_EQ(back.method, "sift");
  ASSERT_EQ(back.tracks.size(), 2u);
  EXPECT_EQ(back.tracks[0].point, 0);
  EXPECT_EQ(back.tracks[1].point, -1);
  ASSERT_EQ(back.tracks[0].observations.size(), 3u);
  EXPECT_EQ(back.tracks[0].observations[2].frame, 2);
  EXPECT_FLOAT_EQ(back.tracks[0].observations[0].y, 20.25f);
  EXPECT_EQ(back.observations_per_frame(), (std::vector<std::size_t>{1, 2, 2}));
}

TEST(Tracks, ReaderRejectsMalformedFiles) {
  TempDir dir;
  write_tracks(dir / "good.json", small_set());
  const std::string good = testing::read_text(dir / "good.json");
  auto expect_rejected = [&](const std::string& from, const std::string& to, const std::string& message) {
    std::string text = good;
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    testing::write_text(dir / "bad.json", text);
    try {
      read_tracks(dir / "bad.json");
      ADD_FAILURE() << "accepted: " << to;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    }
  };
  expect_rejected("\"pg-tracks\"", "\"pg-cameras\"", "format");
  expect_rejected("\"version\": 1", "\"version\": 2", "version");
  expect_rejected("[0,10.5,20.25,1,11.0,21.0,2,12.0,22.0]", "[0,10.5,20.25,7,11.0,21.0]", "out of range");
  expect_rejected("[0,10.5,20.25,1,11.0,21.0,2,12.0,22.0]", "[0,10.5,20.25,0,11.0,21.0]", "observed twice");
  expect_rejected("[0,10.5,20.25,1,11.0,21.0,2,12.0,22.0]", "[0,10.5,20.25]", "2 to");
  expect_rejected("[0,10.5,20.25,1,11.0,21.0,2,12.0,22.0]", "[0,10.5,20.25,1,11.0]", "triples");
  expect_rejected("[0,10.5,20.25,1,11.0,21.0,2,12.0,22.0]", "[0,10.5,20.25,1,911.0,21.0]",
                  "outside the image");
  expect_rejected("\"method\"", "\"colour\"", "unknown field");
}

TEST(Tracks, MergeLinksJoinsChainsAndDropsAmbiguousFrames) {
  const std::vector<std::vector<cv::Point2f>> points = {{{1, 1}, {2, 2}}, {{3, 3}}, {{4, 4}, {5, 5}}};
  // 0:0 - 1:0 - 2:0 is one chain; 0:1 - 2:0 would put two points of frame 0 into it (ambiguous).
  const std::vector<Track> plain = merge_links_into_tracks(points, {{0, 0, 1, 0}, {1, 0, 2, 0}});
  ASSERT_EQ(plain.size(), 1u);
  ASSERT_EQ(plain[0].observations.size(), 3u);
  EXPECT_FLOAT_EQ(plain[0].observations[2].x, 4.0f);
  const std::vector<Track> ambiguous =
      merge_links_into_tracks(points, {{0, 0, 1, 0}, {1, 0, 2, 0}, {0, 1, 2, 0}});
  ASSERT_EQ(ambiguous.size(), 1u);
  ASSERT_EQ(ambiguous[0].observations.size(), 2u);  // frame 0 dropped
  EXPECT_EQ(ambiguous[0].observations[0].frame, 1);
}

TEST(Tracks, MergeLinksKeepsOneOfCoincidentPointsOfAFrame) {
  // Frame 0 holds one keypoint twice (SIFT: two orientations at one place) and a point 3 px away.
  const std::vector<std::vector<cv::Point2f>> points = {{{10, 10}, {10, 10}, {13, 10}}, {{3, 3}}, {{4, 4}}};
  const std::vector<NodeTrack> coincident =
      link_components(points, {{0, 0, 1, 0}, {1, 0, 2, 0}, {0, 1, 2, 0}});
  ASSERT_EQ(coincident.size(), 1u);
  EXPECT_EQ(coincident[0], (NodeTrack{{0, 0}, {1, 0}, {2, 0}}));  // frame 0 kept once, its first node
  const std::vector<NodeTrack> apart = link_components(points, {{0, 0, 1, 0}, {1, 0, 2, 0}, {0, 2, 2, 0}});
  ASSERT_EQ(apart.size(), 1u);
  EXPECT_EQ(apart[0], (NodeTrack{{1, 0}, {2, 0}}));  // two different places: frame 0 is ambiguous
}

// Four cameras on an arc around the origin and the exact fundamental matrices of their pairs.
struct ThreeViewScene {
  std::vector<Camera> cameras;
  std::vector<VerifiedPair> pairs;
  TrackObservation observe(int frame, const Eigen::Vector3d& X) const {
    Eigen::Vector2d px;
    EXPECT_TRUE(cameras[frame].project_world(X, px));
    return {frame, static_cast<float>(px.x()), static_cast<float>(px.y())};
  }
};

ThreeViewScene three_view_scene() {
  ThreeViewScene s;
  for (int v = 0; v < 4; ++v) {
    Camera c;
    c.width = 640;
    c.height = 480;
    c.intrinsics = {500, 500, 319.5, 239.5};
    const double a = 0.3 * v;
    c.cam_from_world = Rigid3::look_at({5 * std::sin(a), 0.4 * v, -5 * std::cos(a)}, {0, 0, 0});
    s.cameras.push_back(c);
  }
  const cv::Matx33d K(500, 0, 319.5, 0, 500, 239.5, 0, 0, 1);
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      const Rigid3 b_from_a = s.cameras[b].cam_from_world * s.cameras[a].cam_from_world.inverse();
      const Eigen::Matrix3d R = b_from_a.rotation.toRotationMatrix();
      const Eigen::Vector3d t = b_from_a.translation;
      Eigen::Matrix3d tx;
      tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
      const Eigen::Matrix3d E = tx * R;
      cv::Matx33d Ec;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) Ec(r, c) = E(r, c);
      VerifiedPair pair{a, b, 100, 100, false};
      pair.fundamental = K.inv().t() * Ec * K.inv();
      s.pairs.push_back(pair);
    }
  return s;
}

TEST(Tracks, ThreeViewCheckDropsTheObservationThatContradictsTheOthers) {
  const ThreeViewScene s = three_view_scene();
  const Eigen::Vector3d X(0.2, -0.1, 0.3), Y(-0.6, 0.5, -0.2);
  // Exact observations satisfy every pair's epipolar constraint.
  for (int a = 0; a < 4; ++a)
    for (const VerifiedPair& p : s.pairs)
      if (p.a == a) {
        const TrackObservation oa = s.observe(p.a, X), ob = s.observe(p.b, X);
        EXPECT_LT(sampson_distance(p.fundamental, {oa.x, oa.y}, {ob.x, ob.y}), 1e-3);
      }
  std::vector<Track> tracks(3);
  tracks[0].observations = {s.observe(0, X), s.observe(1, X), s.observe(2, X), s.observe(3, X)};
  // Frame 3 sees another point: it contradicts frames 0, 1 and 2, which agree with each other.
  tracks[1].observations = {s.observe(0, X), s.observe(1, X), s.observe(2, X), s.observe(3, Y)};
  // Frames 0 and 2 disagree and frame 1 cannot tell which is right: the track goes.
  tracks[2].observations = {s.observe(0, X), s.observe(1, X), s.observe(2, Y)};
  std::vector<VerifiedPair> only_02 = {s.pairs[1]};  // (0, 2)
  ASSERT_EQ(only_02[0].a, 0);
  ASSERT_EQ(only_02[0].b, 2);
  std::vector<Track> first_two(tracks.begin(), tracks.begin() + 2);
  EXPECT_EQ(enforce_track_consistency(first_two, s.pairs, 1.0), 1);
  ASSERT_EQ(first_two.size(), 2u);
  EXPECT_EQ(first_two[0].observations.size(), 4u);
  ASSERT_EQ(first_two[1].observations.size(), 3u);
  EXPECT_EQ(first_two[1].observations.back().frame, 2);
  std::vector<Track> last{tracks[2]};
  EXPECT_EQ(enforce_track_consistency(last, only_02, 1.0), 3);
  EXPECT_TRUE(last.empty());
}

// A textured image and a copy under a known homography: verified SIFT matches follow it.
TEST(Features, SiftMatchesFollowAKnownHomography) {
  const cv::Mat base = blurred_noise(cv::Size(640, 480), 7);
  cv::Matx33d H(0.95, 0.05, 12, -0.04, 0.97, 8, 1e-5, 2e-5, 1);
  cv::Mat warped;
  cv::warpPerspective(base, warped, cv::Mat(H), base.size(), cv::INTER_CUBIC);
  const FrameFeatures a = detect_sift(base, {}, 4000), b = detect_sift(warped, {}, 4000);
  const std::vector<FeatureMatch> matches = match_features(a, b);
  ASSERT_GT(matches.size(), 200u);
  std::size_t close = 0;
  for (const FeatureMatch& m : matches) {
    const cv::Point2f p = a.points[m.a], q = b.points[m.b];
    const cv::Vec3d h = H * cv::Vec3d(p.x, p.y, 1);
    const double dx = h[0] / h[2] - q.x, dy = h[1] / h[2] - q.y;
    if (std::hypot(dx, dy) < 1.0) ++close;
  }
  EXPECT_GT(close, matches.size() * 9 / 10);
}

// detect_sift keeps OpenCV's SIFT descriptors in a byte a value, which loses nothing because OpenCV's
// float values are whole numbers from 0 to 255; root_sift makes unit-length rows of them.
TEST(Features, StoredDescriptorsAreOpenCvsExactly) {
  const cv::Mat image = blurred_noise(cv::Size(640, 480), 9);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat opencv;
  cv::SIFT::create(0, 3, 0.02, 10, 1.6)->detectAndCompute(image, cv::noArray(), keypoints, opencv);
  ASSERT_EQ(opencv.type(), CV_32F);
  ASSERT_GT(opencv.rows, 500);
  int fractional = 0;
  for (int r = 0; r < opencv.rows; ++r)
    for (int c = 0; c < opencv.cols; ++c) {
      const float v = opencv.at<float>(r, c);
      fractional += v != std::round(v) || v < 0 || v > 255;
    }
  EXPECT_EQ(fractional, 0);
  const FrameFeatures features = detect_sift(image, {}, 0);
  ASSERT_EQ(features.descriptors.rows, opencv.rows);
  ASSERT_EQ(features.descriptors.type(), CV_8U);
  // Stored strongest first: row 0 is the first keypoint of the highest response.
  const auto strongest =
      std::max_element(keypoints.begin(), keypoints.end(),
                       [](const auto& a, const auto& b) { return a.response < b.response; });
  cv::Mat expected;
  opencv.row(static_cast<int>(strongest - keypoints.begin())).convertTo(expected, CV_32F);
  cv::Mat stored;
  features.descriptors.row(0).convertTo(stored, CV_32F);
  EXPECT_EQ(cv::norm(expected, stored, cv::NORM_INF), 0);
  const cv::Mat root = root_sift(features.descriptors);
  for (int r = 0; r < root.rows; ++r) EXPECT_NEAR(cv::norm(root.row(r)), 1.0, 1e-5) << "row " << r;
}

// Pixel (0, 0) is the centre of the top-left pixel: a keypoint at x in an image lies at width - 1 - x
// in its mirror image, on average to a few hundredths of a pixel. A bias d in the detector's
// positions shows as a mean offset of 2d: OpenCV's uncorrected 0.25 px (detect_sift) as 0.5 px.
TEST(Features, KeypointsArePlacedInPixelCentreCoordinates) {
  const cv::Mat base = blurred_noise(cv::Size(640, 480), 5);
  cv::Mat mirrored;
  cv::flip(base, mirrored, 1);
  const FrameFeatures a = detect_sift(base, {}, 0), b = detect_sift(mirrored, {}, 0);
  double sum_x = 0;
  int pairs = 0;
  for (std::size_t i = 0; i < a.points.size(); ++i)
    for (std::size_t j = 0; j < b.points.size(); ++j) {
      const double dx = (base.cols - 1 - a.points[i].x) - b.points[j].x, dy = a.points[i].y - b.points[j].y;
      if (std::abs(dx) < 1.5 && std::abs(dy) < 1.5 && std::abs(a.shapes[i].size - b.shapes[j].size) < 0.1) {
        sum_x += dx, ++pairs;
        break;
      }
    }
  ASSERT_GT(pairs, 200);
  EXPECT_LT(std::abs(sum_x / pairs), 0.03);
}

// The exhaustive matcher finds what OpenCV's brute-force matcher finds: the same nearest neighbours,
// the same ratio-test and mutual-check decisions, whichever dot-product kernel this processor runs.
// Queries are noisy copies of indexed rows, some of them ambiguous (a second row close to the first),
// with more rows than one tile on both sides and a descriptor length that is not a multiple of 8.
TEST(Features, ExhaustiveMatchingAgreesWithBruteForce) {
  for (const int dims : {128, 36}) {
    cv::Mat data(700, dims, CV_32F), queries(600, dims, CV_32F);
    cv::RNG rng(11);
    rng.fill(data, cv::RNG::UNIFORM, 0.0, 1.0);
    rng.fill(queries, cv::RNG::NORMAL, 0.0, 0.12);
    queries += data.rowRange(0, queries.rows);
    for (int r = 0; r < 100; ++r) data.row(600 + r) = data.row(r) + 0.05;  // ambiguous twins
    cv::BFMatcher brute(cv::NORM_L2);
    std::vector<std::vector<cv::DMatch>> ab, ba;
    brute.knnMatch(queries, data, ab, 2);
    brute.knnMatch(data, queries, ba, 1);
    for (const bool mutual : {false, true}) {
      std::vector<std::pair<int, int>> expected, found;
      for (const auto& m : ab) {
        if (m[0].distance >= 0.8f * m[1].distance) continue;
        if (mutual && ba[m[0].trainIdx][0].trainIdx != m[0].queryIdx) continue;
        expected.push_back({m[0].queryIdx, m[0].trainIdx});
      }
      for (const FeatureMatch& m : match_descriptors(queries, data, 0.8, mutual)) found.push_back({m.a, m.b});
      ASSERT_GT(expected.size(), 400u);
      EXPECT_LT(expected.size(), 600u);  // the twins fail the ratio test
      EXPECT_EQ(found, expected) << dims << " dimensions, mutual " << mutual << ", vectorised kernel "
                                 << descriptor_dots_vectorised();
    }
  }
}

// Every product of both kernels (the one this processor runs, and the portable one) agrees with a
// double-precision dot product, on every shape the vector kernel's blocking leaves (rows of a in
// fours, of b in twos, and their remainders), and writes nothing past each row.
TEST(Features, DescriptorDotsAreExactToFloatRounding) {
  for (const auto& [rows_a, rows_b, dims] :
       {std::tuple{7, 5, 128}, std::tuple{4, 2, 8}, std::tuple{3, 9, 13}}) {
    cv::Mat a(rows_a, dims, CV_32F), b(rows_b, dims, CV_32F);
    cv::RNG rng(3);
    rng.fill(a, cv::RNG::UNIFORM, -1.0, 1.0);
    rng.fill(b, cv::RNG::UNIFORM, -1.0, 1.0);
    for (const auto kernel : {&descriptor_dots, &descriptor_dots_portable}) {
      std::vector<float> out(static_cast<std::size_t>(rows_a) * (rows_b + 3), -99.0f);
      kernel(a.ptr<float>(), rows_a, b.ptr<float>(), rows_b, dims, out.data(), rows_b + 3);
      for (int i = 0; i < rows_a; ++i) {
        for (int j = 0; j < rows_b; ++j) {
          double dot = 0;
          for (int k = 0; k < dims; ++k) dot += double(a.at<float>(i, k)) * b.at<float>(j, k);
          EXPECT_NEAR(out[i * (rows_b + 3) + j], dot, 1e-5)
              << i << "," << j << " of " << rows_a << "x" << rows_b;
        }
        EXPECT_EQ(out[i * (rows_b + 3) + rows_b], -99.0f);  // past the row: untouched
      }
    }
  }
}

// Counts the bytes OpenCV allocates for Mats through it (current and peak), passing the work on to
// the allocator it wraps.
class CountingMatAllocator final : public cv::MatAllocator {
 public:
  explicit CountingMatAllocator(cv::MatAllocator* inner) : inner_(inner) {}

  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag flags,
                         cv::UMatUsageFlags usage) const override {
    cv::UMatData* u = inner_->allocate(dims, sizes, type, data, step, flags, usage);
    if (u) {
      u->currAllocator = this;
      if (!(u->flags & cv::UMatData::USER_ALLOCATED)) {
        const std::int64_t now = current_ += static_cast<std::int64_t>(u->size);
        for (std::int64_t seen = peak_; now > seen && !peak_.compare_exchange_weak(seen, now);) {
        }
      }
    }
    return u;
  }
  bool allocate(cv::UMatData* u, cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    return inner_->allocate(u, flags, usage);
  }
  void deallocate(cv::UMatData* u) const override {
    if (u && !(u->flags & cv::UMatData::USER_ALLOCATED)) current_ -= static_cast<std::int64_t>(u->size);
    inner_->deallocate(u);
  }
  std::uint64_t peak() const { return static_cast<std::uint64_t>(peak_.load()); }

 private:
  cv::MatAllocator* inner_;
  mutable std::atomic<std::int64_t> current_{0}, peak_{0};
};

// build_correspondences runs as many detections at once as sift_detection_bytes lets fit in memory:
// the estimate must cover the most a detection's images (its scale space) take at once, and not by so
// much that it wastes the budget.
TEST(Features, SiftDetectionBytesCoverWhatADetectionTakes) {
  const cv::Mat image = blurred_noise(cv::Size(1600, 1200), 3);
  cv::MatAllocator* standard = cv::Mat::getDefaultAllocator();
  CountingMatAllocator counting(standard);
  cv::Mat::setDefaultAllocator(&counting);
  const FrameFeatures features = detect_sift(image, cv::Mat(), 8000);
  cv::Mat::setDefaultAllocator(standard);
  const std::uint64_t estimate = sift_detection_bytes(image.size());
  std::cout << "[ measured ] SIFT on 1600x1200: " << (counting.peak() >> 20) << " MiB of images at the peak, "
            << "estimated " << (estimate >> 20) << " MiB\n";
  EXPECT_EQ(features.points.size(), 8000u);
  EXPECT_LE(counting.peak(), estimate);
  EXPECT_GT(counting.peak(), estimate * 17 / 20);
}

// KLT holds two frames at a time and what klt_tracking_bytes says it builds from them while it tracks;
// the estimate must cover that, and not by so much that it wastes the budget. Both modes, since
// Shi-Tomasi detects corners in every frame.
TEST(Klt, TrackingBytesCoverWhatTrackingTakes) {
  const cv::Mat base = blurred_noise(cv::Size(1600, 1200), 3);
  cv::Mat shifted;
  cv::warpAffine(base, shifted, cv::Mat(cv::Matx23d(1, 0, 3.5, 0, 1, -2.25)), base.size(), cv::INTER_CUBIC,
                 cv::BORDER_REFLECT);
  const std::vector<cv::Mat> frames{base, shifted, base};
  for (bool redetect : {false, true}) {
    KltOptions options;
    options.redetect_every_frame = redetect;
    cv::MatAllocator* standard = cv::Mat::getDefaultAllocator();
    CountingMatAllocator counting(standard);
    cv::Mat::setDefaultAllocator(&counting);
    const auto tracked = track_klt(frames, {}, options);
    cv::Mat::setDefaultAllocator(standard);
    const std::uint64_t estimate = klt_tracking_bytes(base.size());
    std::cout << "[ measured ] KLT on 1600x1200" << (redetect ? " (Shi-Tomasi)" : "") << ": "
              << (counting.peak() >> 20) << " MiB of images at the peak, estimated " << (estimate >> 20)
              << " MiB\n";
    EXPECT_GT(tracked[2].size(), 1000u);
    EXPECT_LE(counting.peak(), estimate);
    EXPECT_GT(counting.peak(), estimate * 17 / 20);
  }
}

// What a tool checks against --max-memory before decoding: every frame's features, and one SIFT
// detection with the image it searches (here more than decoding one file, or a KLT step). Neither
// mode need keep the working images: SIFT decodes them again when it refines positions, KLT streams
// them two at a time.
TEST(Correspondences, MemoryNeededIsTheFeaturesAndOneDetection) {
  TempDir dir;
  std::vector<SequenceFrame> frames;
  for (int f = 0; f < 3; ++f) {
    const auto path = dir / ("f" + std::to_string(f) + ".png");
    cv::imwrite(path.string(), blurred_noise(cv::Size(320, 240), f));
    frames.push_back({std::to_string(f), path, {}});
  }
  CorrespondenceOptions options;
  options.max_features = 1000;
  const std::uint64_t features = 3 * 1000 * sift_feature_bytes;
  EXPECT_EQ(correspondence_memory_bytes(frames, options),
            features + 320 * 240 + sift_detection_bytes({320, 240}));
  options.downscale = 2;
  EXPECT_EQ(correspondence_memory_bytes(frames, options),
            features + 160 * 120 + sift_detection_bytes({160, 120}));
  options.method = CorrespondenceMethod::klt;  // keeps half as many SIFT features
  EXPECT_EQ(correspondence_memory_bytes(frames, options),
            features / 2 + 160 * 120 + sift_detection_bytes({160, 120}));
  frames.push_back({"missing", dir / "missing.png", {}});
  EXPECT_THROW(correspondence_memory_bytes(frames, options), InputError);
}

// Streamed, track_klt asks for each frame once, in order, and holds at most two: a frame's image is
// released (its buffer no longer shared) by the time the frame two after it is asked for. The tracks
// are those of the frames held.
TEST(Klt, StreamedFramesAreLoadedOnceInOrderAndGiveTheSameTracks) {
  const cv::Mat base = blurred_noise(cv::Size(320, 240), 3);
  std::vector<cv::Mat> frames;
  for (int f = 0; f < 5; ++f) {
    cv::Mat shifted;
    cv::warpAffine(base, shifted, cv::Mat(cv::Matx23d(1, 0, 1.5 * f, 0, 1, -0.75 * f)), base.size(),
                   cv::INTER_CUBIC, cv::BORDER_REFLECT);
    frames.push_back(shifted);
  }
  KltOptions options;
  options.max_corners = 300;
  std::vector<int> asked;
  std::vector<cv::Mat> handed;  // each frame's copy, to see when track_klt lets go of it
  const auto streamed = track_klt(
      static_cast<int>(frames.size()),
      [&](int f) {
        for (std::size_t older = 0; older + 1 < handed.size(); ++older)
          EXPECT_EQ(handed[older].u->refcount, 1) << "frame " << older << " still held at frame " << f;
        asked.push_back(f);
        handed.push_back(frames[f].clone());
        return KltFrame{handed.back(), {}};
      },
      options);
  EXPECT_EQ(asked, (std::vector<int>{0, 1, 2, 3, 4}));
  const auto held = track_klt(frames, {}, options);
  ASSERT_EQ(streamed.size(), held.size());
  for (std::size_t f = 0; f < held.size(); ++f) {
    ASSERT_EQ(streamed[f].size(), held[f].size()) << "frame " << f;
    for (std::size_t i = 0; i < held[f].size(); ++i) {
      EXPECT_EQ(streamed[f][i].track, held[f][i].track);
      EXPECT_EQ(streamed[f][i].position, held[f][i].position);
    }
  }
  EXPECT_GT(held[4].size(), 200u);
}

TEST(Klt, TracksAShiftedImageToSubPixelAccuracy) {
  const cv::Mat base = blurred_noise(cv::Size(320, 240), 3);
  std::vector<cv::Mat> frames{base};
  for (int f = 1; f < 4; ++f) {
    cv::Mat shifted;
    const cv::Matx23d shift(1, 0, 2.5 * f, 0, 1, -1.25 * f);
    cv::warpAffine(base, shifted, cv::Mat(shift), base.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
    frames.push_back(shifted);
  }
  for (bool redetect : {false, true}) {
    KltOptions options;
    options.max_corners = 300;
    options.redetect_every_frame = redetect;
    const auto tracked = track_klt(frames, {}, options);
    std::map<int, cv::Point2f> first;
    for (const KltPoint& p : tracked[0]) first[p.track] = p.position;
    std::size_t checked = 0;
    for (const KltPoint& p : tracked[3]) {
      if (!first.count(p.track)) continue;
      const cv::Point2f expected = first[p.track] + cv::Point2f(7.5f, -3.75f);
      // Away from the reflected border, where the shifted image is not a shift.
      if (expected.x < 20 || expected.y < 20 || expected.x > 300 || expected.y > 220) continue;
      EXPECT_NEAR(p.position.x, expected.x, redetect ? 0.6 : 0.1);
      EXPECT_NEAR(p.position.y, expected.y, redetect ? 0.6 : 0.1);
      ++checked;
    }
    EXPECT_GT(checked, 100u) << "redetect " << redetect;
  }
}

}  // namespace
}  // namespace pg
