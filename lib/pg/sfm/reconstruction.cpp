#include "pg/sfm/reconstruction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <optional>

#include "pg/camera/size_check.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/geometry/triangulation.h"
#include "pg/sfm/bundle_adjustment.h"

namespace pg {

double default_focal_guess(int width, int height) {
  return 1.2 * std::max(width, height);
}

namespace {

constexpr double deg = M_PI / 180.0;

Rigid3 rigid_from_params(const PoseParams& p) {
  const Eigen::Vector3d aa(p[0], p[1], p[2]);
  const double angle = aa.norm();
  Rigid3 r;
  r.rotation =
      angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, aa / angle)) : Eigen::Quaterniond::Identity();
  r.translation = Eigen::Vector3d(p[3], p[4], p[5]);
  return r;
}

PoseParams params_from_rigid(const Rigid3& r) {
  const Eigen::AngleAxisd aa(r.rotation.normalized());
  const Eigen::Vector3d v = aa.axis() * aa.angle();
  return {v.x(), v.y(), v.z(), r.translation.x(), r.translation.y(), r.translation.z()};
}

// Whether the distortion holds terms beyond k1 and k2 (observations are then undistorted up front).
bool beyond_radial2(const Distortion& d) {
  return d.p1 != 0 || d.p2 != 0 || d.k3 != 0 || d.k4 != 0 || d.k5 != 0 || d.k6 != 0;
}

class Mapper {
 public:
  Mapper(const TrackSet& tracks, const std::vector<Camera>& initial, const SfmOptions& options)
      : tracks_(tracks), initial_(initial), opt_(options), n_(static_cast<int>(tracks.frames.size())) {
    principal_point_free_ = options.principal_point == PrincipalPointMode::refine;
    setup_intrinsics();
    setup_observations();
    poses_.assign(n_, PoseParams{});
    registered_.assign(n_, false);
    failed_at_.assign(n_, 0);
    track_point_.assign(tracks_.tracks.size(), -1);
  }

  SfmResult run() {
    initialise();
    register_all(opt_.min_pnp_inliers);
    // A second chance with a lower bar once the model is complete and adjusted.
    if (registered_count() < n_) {
      global_round(true);
      std::fill(failed_at_.begin(), failed_at_.end(), 0);
      register_all(std::max(8, opt_.min_pnp_inliers / 2));
    }
    adapt_bound_ = opt_.bound_sigmas > 0;
    for (int round = 0; round < 2; ++round) {
      retriangulate_all();
      global_round(true);
    }
    const BundleSummary final_fit = final_bundle();
    if (opt_.principal_point == PrincipalPointMode::when_better && opt_.refine_focal &&
        !principal_point_free_)
      try_principal_point(final_fit.final_rms_px);
    filter_points();
    return result();
  }

 private:
  // ---- setup ----
  void setup_intrinsics() {
    group_.resize(n_);
    for (int f = 0; f < n_; ++f) {
      const Camera& c = initial_[f];
      if (c.model != CameraModel::pinhole) throw UsageError("tracking supports pinhole cameras only");
      group_[f] = opt_.shared_intrinsics ? 0 : f;
      if (opt_.shared_intrinsics)
        require_same_size(tracks_.frames[f].image, {tracks_.frames[f].id, c.width, c.height},
                          {tracks_.frames[0].id, initial_[0].width, initial_[0].height});
      if (opt_.shared_intrinsics && f > 0) continue;
      const Distortion& d = c.distortion;
      const bool radial_only = !beyond_radial2(d);
      intrinsics_.push_back({c.intrinsics.fx, c.intrinsics.cx, c.intrinsics.cy, radial_only ? d.k1 : 0.0,
                             radial_only ? d.k2 : 0.0});
      aspect_.push_back(c.intrinsics.fy / c.intrinsics.fx);
    }
  }

  void setup_observations() {
    obs_.resize(tracks_.tracks.size());
    frame_obs_.resize(n_);
    for (std::size_t t = 0; t < tracks_.tracks.size(); ++t) {
      for (const TrackObservation& o : tracks_.tracks[t].observations) {
        Eigen::Vector2d px(o.x, o.y);
        const Camera& c = initial_[o.frame];
        if (beyond_radial2(c.distortion)) {
          // Observations in an ideal pinhole image of the same intrinsics.
          const Eigen::Vector2d xn((px.x() - c.intrinsics.cx) / c.intrinsics.fx,
                                   (px.y() - c.intrinsics.cy) / c.intrinsics.fy);
          const Eigen::Vector2d u = undistort_pinhole(c.distortion, xn);
          px = {c.intrinsics.fx * u.x() + c.intrinsics.cx, c.intrinsics.fy * u.y() + c.intrinsics.cy};
        }
        frame_obs_[o.frame].push_back({static_cast<int>(t), static_cast<int>(obs_[t].size())});
        obs_[t].push_back({o.frame, px});
      }
    }
  }

  // ---- small helpers ----
  struct Obs {
    int frame;
    Eigen::Vector2d pixel;
  };
  const IntrinsicParams& intr(int f) const { return intrinsics_[group_[f]]; }
  double aspect(int f) const { return aspect_[group_[f]]; }
  double focal(int f) const { return intr(f)[0]; }
  double threshold() const { return bound_px_; }
  int registered_count() const {
    return static_cast<int>(std::count(registered_.begin(), registered_.end(), true));
  }

  // Camera-frame ray (x, y, 1) of a pixel.
  Eigen::Vector3d ray(int f, const Eigen::Vector2d& px) const {
    const IntrinsicParams& k = intr(f);
    const Eigen::Vector2d xd((px.x() - k[1]) / k[0], (px.y() - k[2]) / (k[0] * aspect(f)));
    Distortion d;
    d.k1 = k[3];
    d.k2 = k[4];
    const Eigen::Vector2d x = d.is_zero() ? xd : undistort_pinhole(d, xd);
    return {x.x(), x.y(), 1.0};
  }

  // Projection of X in frame f minus the observed pixel; none when X is behind the camera.
  std::optional<Eigen::Vector2d> residual(int f, const Eigen::Vector3d& X, const Eigen::Vector2d& px) const {
    Eigen::Vector2d projected;
    if (!project_with_params(poses_[f], intr(f), aspect(f), X, projected)) return std::nullopt;
    return projected - px;
  }

  double reprojection_error(int f, const Eigen::Vector3d& X, const Eigen::Vector2d& px) const {
    const std::optional<Eigen::Vector2d> r = residual(f, X, px);
    return r ? r->norm() : 1e9;
  }

  Eigen::Vector3d centre(int f) const { return rigid_from_params(poses_[f]).centre(); }

  // ---- points ----
  struct Point {
    Eigen::Vector3d position;
    int track;
    std::vector<int> obs;  // indices into obs_[track]
    bool alive = true;
  };

  int add_point(int t, const Eigen::Vector3d& X, std::vector<int> used) {
    points_.push_back({X, t, std::move(used), true});
    track_point_[t] = static_cast<int>(points_.size()) - 1;
    return track_point_[t];
  }

  void kill_point(int p) {
    points_[p].alive = false;
    track_point_[points_[p].track] = -1;
  }

  double max_angle(const std::vector<int>& used, int t, const Eigen::Vector3d& X) const {
    double best = 0;
    for (std::size_t i = 0; i < used.size(); ++i)
      for (std::size_t j = i + 1; j < used.size(); ++j)
        best = std::max(
            best, triangulation_angle(centre(obs_[t][used[i]].frame), centre(obs_[t][used[j]].frame), X));
    return best;
  }

  std::optional<Eigen::Vector3d> triangulate_subset(int t, const std::vector<int>& used) const {
    std::vector<Rigid3> poses;
    std::vector<Eigen::Vector3d> rays;
    for (int k : used) {
      poses.push_back(rigid_from_params(poses_[obs_[t][k].frame]));
      rays.push_back(ray(obs_[t][k].frame, obs_[t][k].pixel));
    }
    return triangulate(poses, rays);
  }

  std::vector<int> inliers_of(int t, const Eigen::Vector3d& X, const std::vector<int>& candidates) const {
    std::vector<int> in;
    for (int k : candidates)
      if (reprojection_error(obs_[t][k].frame, X, obs_[t][k].pixel) < threshold()) in.push_back(k);
    return in;
  }

  // The best point for track t from its registered observations, and the observations it explains;
  // robust to a few outlying observations by trying pairs when the joint estimate does not explain
  // every observation.
  std::vector<int> robust_triangulation(int t, Eigen::Vector3d& best_X) const {
    std::vector<int> candidates;
    for (int k = 0; k < static_cast<int>(obs_[t].size()); ++k)
      if (registered_[obs_[t][k].frame]) candidates.push_back(k);
    std::vector<int> best_in;
    if (candidates.size() < 2) return best_in;
    if (auto X = triangulate_subset(t, candidates)) {
      best_in = inliers_of(t, *X, candidates);
      best_X = *X;
    }
    if (best_in.size() < candidates.size()) {
      const std::size_t limit = std::min<std::size_t>(candidates.size(), 8);
      for (std::size_t i = 0; i < limit; ++i)
        for (std::size_t j = i + 1; j < limit; ++j) {
          auto X = triangulate_subset(t, {candidates[i], candidates[j]});
          if (!X) continue;
          std::vector<int> in = inliers_of(t, *X, candidates);
          if (in.size() > best_in.size()) best_in = std::move(in), best_X = *X;
        }
      if (best_in.size() >= 2) {
        if (auto X = triangulate_subset(t, best_in)) {
          std::vector<int> in = inliers_of(t, *X, candidates);
          if (in.size() >= best_in.size()) best_in = std::move(in), best_X = *X;
        }
      }
    }
    if (best_in.size() < 2 || max_angle(best_in, t, best_X) < opt_.min_triangulation_angle_deg * deg)
      best_in.clear();
    return best_in;
  }

  bool triangulate_track(int t) {
    if (track_point_[t] >= 0) return false;
    Eigen::Vector3d X;
    std::vector<int> used = robust_triangulation(t, X);
    if (used.empty()) return false;
    add_point(t, X, std::move(used));
    return true;
  }

  // A point triangulated from few views may be wrong where a moved observation slid along the
  // epipolar line; once more views are registered, the track is triangulated again and the point
  // replaced when the new estimate explains more observations.
  bool repair_point(int p) {
    Point& point = points_[p];
    int registered_obs = 0;
    for (const Obs& o : obs_[point.track]) registered_obs += registered_[o.frame] ? 1 : 0;
    if (static_cast<int>(point.obs.size()) >= registered_obs) return false;
    Eigen::Vector3d X;
    std::vector<int> used = robust_triangulation(point.track, X);
    if (used.size() <= point.obs.size()) return false;
    point.position = X;
    point.obs = std::move(used);
    return true;
  }

  // Adds the observations of frame f to the points its tracks already have, where they agree.
  void extend_points(int f) {
    for (const auto& [t, k] : frame_obs_[f]) {
      const int p = track_point_[t];
      if (p < 0) continue;
      Point& point = points_[p];
      if (std::find(point.obs.begin(), point.obs.end(), k) != point.obs.end()) continue;
      if (reprojection_error(f, point.position, obs_[t][k].pixel) < threshold()) point.obs.push_back(k);
    }
  }

  int triangulate_frame(int f) {
    extend_points(f);
    int created = 0;
    for (const auto& [t, k] : frame_obs_[f]) created += triangulate_track(t) ? 1 : 0;
    return created;
  }

  void retriangulate_all() {
    for (int f = 0; f < n_; ++f)
      if (registered_[f]) extend_points(f);
    int repaired = 0;
    for (std::size_t p = 0; p < points_.size(); ++p)
      if (points_[p].alive) repaired += repair_point(static_cast<int>(p)) ? 1 : 0;
    if (repaired) log::debug("sfm: ", repaired, " points re-triangulated from more views");
    int created = 0;
    for (std::size_t t = 0; t < obs_.size(); ++t) created += triangulate_track(static_cast<int>(t)) ? 1 : 0;
    log::debug("sfm: re-triangulation added ", created, " points");
  }

  // Drops observations beyond the error bound and points left with fewer than two or too small an
  // angle. Returns the number of points removed.
  int filter_points() {
    int removed = 0;
    for (std::size_t p = 0; p < points_.size(); ++p) {
      Point& point = points_[p];
      if (!point.alive) continue;
      point.obs = inliers_of(point.track, point.position, point.obs);
      if (point.obs.size() < 2 ||
          max_angle(point.obs, point.track, point.position) < opt_.min_triangulation_angle_deg * deg) {
        kill_point(static_cast<int>(p));
        ++removed;
      }
    }
    return removed;
  }

  // ---- bundle adjustment ----
  BundleOptions bundle_options(bool global) const {
    BundleOptions b;
    const bool enough = registered_count() >= 3;
    b.refine_focal = global && enough && opt_.refine_focal;
    b.refine_principal_point = global && enough && principal_point_free_;
    b.refine_distortion = global && enough && opt_.refine_distortion;
    b.huber_px = opt_.huber_px * bound_px_ / opt_.max_reprojection_px;
    b.max_iterations = global ? 100 : 30;
    return b;
  }

  BundleSummary bundle(const std::vector<bool>& variable_frame, const BundleOptions& options) {
    BundleProblem problem;
    problem.poses = &poses_;
    problem.intrinsics = &intrinsics_;
    problem.aspect = aspect_;
    problem.frame_group = group_;
    problem.points = &positions_;
    positions_.resize(points_.size());
    std::vector<bool> include(points_.size(), false);
    for (std::size_t p = 0; p < points_.size(); ++p) {
      const Point& point = points_[p];
      if (!point.alive) continue;
      for (int k : point.obs)
        if (variable_frame[obs_[point.track][k].frame]) include[p] = true;
      positions_[p] = point.position;
    }
    for (std::size_t p = 0; p < points_.size(); ++p) {
      if (!include[p]) continue;
      for (int k : points_[p].obs) {
        const Obs& o = obs_[points_[p].track][k];
        problem.observations.push_back({o.frame, static_cast<int>(p), o.pixel});
      }
    }
    problem.frame_constant.resize(n_);
    for (int f = 0; f < n_; ++f) problem.frame_constant[f] = !variable_frame[f] || f == gauge_frame_;
    // The second frame of the initial pair keeps its largest translation component: with the first
    // frame fixed, that fixes the scale, so the normal equations are not singular.
    if (variable_frame[initial_pair_[1]]) {
      problem.scale_frame = initial_pair_[1];
      const PoseParams& pose = poses_[initial_pair_[1]];
      int axis = 0;
      for (int k = 1; k < 3; ++k)
        if (std::abs(pose[3 + k]) > std::abs(pose[3 + axis])) axis = k;
      problem.scale_axis = axis;
    }
    const BundleSummary summary = bundle_adjust(problem, options);
    for (std::size_t p = 0; p < points_.size(); ++p)
      if (include[p]) points_[p].position = positions_[p];
    return summary;
  }

  BundleSummary global_bundle(const BundleOptions& options) { return bundle(registered_, options); }

  BundleSummary final_bundle() {
    BundleOptions options = bundle_options(true);
    options.max_iterations = 200;
    options.function_tolerance = 1e-10;
    return global_bundle(options);
  }

  // Frees the principal point in one more final adjustment of the model; keeps the result only when
  // the reprojection RMS drops by principal_point_min_gain, else restores the model. (Re-triangulating
  // and adjusting again after it cost 20-60% more adjustment time for no gain on entry-P10,
  // Herz-Jesus-P8 and templeSparseRing.)
  void try_principal_point(double fixed_rms_px) {
    const std::vector<PoseParams> poses = poses_;
    const std::vector<IntrinsicParams> intrinsics = intrinsics_;
    const std::vector<Point> points = points_;
    principal_point_free_ = true;
    // The trial stops after 25 iterations, not at the final adjustment's 1e-10: a freed principal point
    // drifts slowly along the valley it shares with the poses (templeRing: 179 iterations, 15 s of a
    // 45 s run, for an RMS change of 0.1% against the 0.5% asked). A kept result is then adjusted to the
    // final tolerance.
    BundleOptions trial = bundle_options(true);
    trial.max_iterations = 25;
    const BundleSummary s = global_bundle(trial);
    const double free_rms_px = s.final_rms_px;
    const bool better = free_rms_px <= fixed_rms_px * (1 - opt_.principal_point_min_gain);
    log::info("sfm: freeing the principal point moves the reprojection RMS from ", fixed_rms_px, " to ",
              free_rms_px, " px: ", better ? "refined" : "kept at its start");
    log::debug("sfm: principal point trial: ", s.iterations, " iterations");
    if (better) {
      final_bundle();
      return;
    }
    principal_point_free_ = false;
    poses_ = poses;
    intrinsics_ = intrinsics;
    points_ = points;
  }

  // The observations' noise, per image axis: 1.4826 x the median absolute residual coordinate,
  // scaled up by the degrees of freedom the points took (a point seen twice fits four coordinates
  // with three parameters, so its residuals are half the noise).
  double robust_sigma_px() const {
    std::vector<double> residuals;
    std::size_t point_count = 0;
    for (const Point& point : points_) {
      if (!point.alive) continue;
      ++point_count;
      for (int k : point.obs) {
        const Obs& o = obs_[point.track][k];
        const std::optional<Eigen::Vector2d> r = residual(o.frame, point.position, o.pixel);
        if (!r) continue;
        residuals.push_back(std::abs(r->x()));
        residuals.push_back(std::abs(r->y()));
      }
    }
    const double free_coordinates = static_cast<double>(residuals.size()) - 3.0 * point_count;
    if (residuals.size() < 100 || free_coordinates <= 0) return 0;
    auto middle = residuals.begin() + residuals.size() / 2;
    std::nth_element(residuals.begin(), middle, residuals.end());
    return 1.4826 * *middle * std::sqrt(residuals.size() / free_coordinates);
  }

  // The outlier bound follows the observations' noise: bound_sigmas x sigma, between
  // min_reprojection_px and max_reprojection_px, the Huber scale in proportion.
  void adapt_bound() {
    if (!adapt_bound_) return;
    const double sigma = robust_sigma_px();
    if (sigma <= 0) return;
    bound_px_ =
        std::min(opt_.max_reprojection_px, std::max(opt_.min_reprojection_px, opt_.bound_sigmas * sigma));
    log::debug("sfm: observation noise ", sigma, " px per axis: outlier bound ", bound_px_, " px");
  }

  void global_round(bool refine) {
    for (int pass = 0; pass < 2; ++pass) {
      const BundleSummary s = global_bundle(bundle_options(refine));
      adapt_bound();
      const int removed = filter_points();
      log::debug("sfm: global adjustment over ", registered_count(), " frames: rms ", s.final_rms_px, " px, ",
                 removed, " points removed");
      if (removed == 0) break;
    }
    last_global_size_ = registered_count();
  }

  void local_round(int f) {
    // The new frame and the registered frames sharing the most points with it.
    std::map<int, int> shared;
    for (const auto& [t, k] : frame_obs_[f]) {
      const int p = track_point_[t];
      if (p < 0) continue;
      for (int j : points_[p].obs) shared[obs_[t][j].frame]++;
    }
    std::vector<std::pair<int, int>> ranked;
    for (const auto& [frame, count] : shared)
      if (frame != f) ranked.push_back({count, frame});
    std::sort(ranked.rbegin(), ranked.rend());
    std::vector<bool> variable(n_, false);
    variable[f] = true;
    for (int i = 0; i < std::min<int>(opt_.local_ba_frames - 1, static_cast<int>(ranked.size())); ++i)
      variable[ranked[i].second] = true;
    bundle(variable, bundle_options(false));
    filter_points();
  }

  // ---- initialisation ----
  struct PairModel {
    int a = -1, b = -1;
    int inliers = 0;
    double median_angle = 0;
    Rigid3 b_from_a;
  };

  PairModel two_view(int a, int b, const std::vector<int>& shared_tracks) const {
    PairModel m;
    m.a = a;
    m.b = b;
    std::vector<cv::Point2d> pa, pb;
    for (int t : shared_tracks) {
      Eigen::Vector3d ra = Eigen::Vector3d::Zero(), rb = Eigen::Vector3d::Zero();
      for (const Obs& o : obs_[t]) {
        if (o.frame == a) ra = ray(a, o.pixel);
        if (o.frame == b) rb = ray(b, o.pixel);
      }
      pa.push_back({ra.x(), ra.y()});
      pb.push_back({rb.x(), rb.y()});
    }
    const double thr = threshold() / std::sqrt(focal(a) * focal(b));
    cv::Mat mask;
    cv::Mat E = cv::findEssentialMat(pa, pb, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.9999, thr, mask);
    if (E.rows != 3 || E.cols != 3) return m;
    cv::Mat R, t;
    m.inliers = cv::recoverPose(E, pa, pb, cv::Mat::eye(3, 3, CV_64F), R, t, mask);
    Eigen::Matrix3d Re;
    Eigen::Vector3d te;
    cv::cv2eigen(R, Re);
    cv::cv2eigen(t, te);
    m.b_from_a.rotation = Eigen::Quaterniond(Re).normalized();
    m.b_from_a.translation = te;
    std::vector<double> angles;
    const Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = m.b_from_a.centre();
    for (std::size_t i = 0; i < pa.size(); ++i) {
      if (!mask.at<unsigned char>(static_cast<int>(i))) continue;
      const Eigen::Vector3d da(pa[i].x, pa[i].y, 1.0);
      const Eigen::Vector3d db = m.b_from_a.rotation.conjugate() * Eigen::Vector3d(pb[i].x, pb[i].y, 1.0);
      auto X = triangulate_midpoint(ca, da.normalized(), cb, db.normalized());
      if (X) angles.push_back(triangulation_angle(ca, cb, *X));
    }
    if (!angles.empty()) {
      std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
      m.median_angle = angles[angles.size() / 2];
    }
    return m;
  }

  void initialise() {
    // Tracks shared by every pair.
    std::map<std::pair<int, int>, std::vector<int>> shared;
    for (std::size_t t = 0; t < obs_.size(); ++t)
      for (std::size_t i = 0; i < obs_[t].size(); ++i)
        for (std::size_t j = i + 1; j < obs_[t].size(); ++j)
          shared[{std::min(obs_[t][i].frame, obs_[t][j].frame), std::max(obs_[t][i].frame, obs_[t][j].frame)}]
              .push_back(static_cast<int>(t));
    std::vector<std::pair<std::size_t, std::pair<int, int>>> ranked;
    for (const auto& [pair, list] : shared)
      if (list.size() >= 30) ranked.push_back({list.size(), pair});
    if (ranked.empty())
      throw FailedError(
          "no two frames share enough correspondences (30) to start: the images do not overlap");
    std::sort(ranked.rbegin(), ranked.rend());
    if (ranked.size() > 30) ranked.resize(30);
    std::vector<PairModel> candidates;
    PairModel most_parallax;
    for (const auto& [count, pair] : ranked) {
      const PairModel m = two_view(pair.first, pair.second, shared[pair]);
      log::debug("sfm: pair ", tracks_.frames[m.a].id, "-", tracks_.frames[m.b].id, ": ", m.inliers,
                 " inliers, median angle ", m.median_angle / deg, " deg");
      if (most_parallax.a < 0 || m.median_angle > most_parallax.median_angle) most_parallax = m;
      if (m.median_angle >= opt_.init_min_angle_deg * deg) candidates.push_back(m);
    }
    if (candidates.empty())
      throw FailedError(
          str("no pair of frames has enough parallax to start (the camera only rotates?): the best, ",
              most_parallax.a >= 0 ? tracks_.frames[most_parallax.a].id : "?", " and ",
              most_parallax.b >= 0 ? tracks_.frames[most_parallax.b].id : "?", ", has a median ",
              "triangulation angle of ", most_parallax.median_angle / deg, " degrees (needs ",
              opt_.init_min_angle_deg, ")"));
    // Most inliers first (stable: ties keep the ranking by shared tracks). A start whose adjustment
    // keeps under a quarter of its points collapsed (a focal guess far from the truth can let the
    // two-view adjustment shrink the baseline): the next candidate is tried.
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const PairModel& x, const PairModel& y) { return x.inliers > y.inliers; });
    for (const PairModel& best : candidates) {
      start_from(best, shared[{best.a, best.b}]);
      const int kept = alive_points();
      if (kept >= std::max(30, best.inliers / 4)) return;
      log::info("sfm: start from ", tracks_.frames[best.a].id, " and ", tracks_.frames[best.b].id,
                " collapsed (", kept, " of ", best.inliers, " points kept); trying the next pair");
    }
    throw FailedError(str("every candidate pair of frames collapsed when adjusted, the first being ",
                          tracks_.frames[candidates[0].a].id, " and ", tracks_.frames[candidates[0].b].id,
                          ": the sequence has too little parallax or wrong correspondences"));
  }

  int alive_points() const {
    return static_cast<int>(
        std::count_if(points_.begin(), points_.end(), [](const Point& p) { return p.alive; }));
  }

  void start_from(const PairModel& best, const std::vector<int>& shared_tracks) {
    points_.clear();
    std::fill(track_point_.begin(), track_point_.end(), -1);
    std::fill(registered_.begin(), registered_.end(), false);
    initial_pair_[0] = best.a;
    initial_pair_[1] = best.b;
    gauge_frame_ = best.a;
    poses_[best.a] = params_from_rigid(Rigid3{});
    poses_[best.b] = params_from_rigid(best.b_from_a);
    registered_[best.a] = registered_[best.b] = true;
    log::info("sfm: starting from frames ", tracks_.frames[best.a].id, " and ", tracks_.frames[best.b].id,
              " (", best.inliers, " inliers, median angle ", best.median_angle / deg, " deg)");
    for (int t : shared_tracks) triangulate_track(t);
    global_round(false);
  }

  // ---- registration ----
  bool register_frame(int f, int min_inliers) {
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    std::vector<Eigen::Vector2d> pixels;  // the observed pixel of each correspondence
    for (const auto& [t, k] : frame_obs_[f]) {
      const int p = track_point_[t];
      if (p < 0) continue;
      const Eigen::Vector3d& X = points_[p].position;
      const Eigen::Vector3d r = ray(f, obs_[t][k].pixel);
      object.push_back({X.x(), X.y(), X.z()});
      image.push_back({r.x(), r.y()});
      pixels.push_back(obs_[t][k].pixel);
    }
    if (static_cast<int>(object.size()) < min_inliers) return false;
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    const double thr = threshold() / focal(f);
    const bool found = cv::solvePnPRansac(object, image, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec,
                                          tvec, false, 2000, thr, 0.9999, inliers, cv::SOLVEPNP_AP3P);
    if (!found || static_cast<int>(inliers.size()) < min_inliers) return false;
    std::vector<cv::Point3d> object_in;
    std::vector<cv::Point2d> image_in;
    for (int i : inliers) object_in.push_back(object[i]), image_in.push_back(image[i]);
    const auto point = [&](std::size_t i) { return Eigen::Vector3d(object[i].x, object[i].y, object[i].z); };
    // solvePnPRansac returns a pose re-estimated from all its inliers (by EPnP for the P3P kernels),
    // which can be far off on a plane seen at a grazing angle: on a checkerboard scene most of 38
    // inliers fell outside the bound, and refinement from there ended 58 degrees out with 20. SQPnP's
    // globally optimal estimate is a second candidate; each is refined, and the one that fits the
    // inliers better is kept, scored as MSAC does (squared reprojection error truncated at the bound;
    // a point behind the camera counts as the bound).
    const double bound2 = threshold() * threshold();
    cv::Mat global_r, global_t;
    std::vector<std::pair<cv::Mat, cv::Mat>> candidates{{rvec, tvec}};
    if (cv::solvePnP(object_in, image_in, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), global_r, global_t,
                     false, cv::SOLVEPNP_SQPNP))
      candidates.push_back({global_r, global_t});
    double best = std::numeric_limits<double>::infinity();
    PoseParams best_pose{};
    for (auto& [r, t] : candidates) {
      cv::solvePnPRefineLM(object_in, image_in, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), r, t);
      poses_[f] = {r.at<double>(0), r.at<double>(1), r.at<double>(2),
                   t.at<double>(0), t.at<double>(1), t.at<double>(2)};
      double score = 0;
      for (int i : inliers) {
        const double e = reprojection_error(f, point(i), pixels[i]);
        score += std::min(e * e, bound2);
      }
      if (score < best) best = score, best_pose = poses_[f];
    }
    poses_[f] = best_pose;
    int count = 0;
    for (std::size_t i = 0; i < object.size(); ++i)
      if (reprojection_error(f, point(i), pixels[i]) < threshold()) ++count;
    log::debug("sfm: frame ", tracks_.frames[f].id, ": ", object.size(), " 2D-3D, ", count, " inliers");
    return count >= min_inliers;
  }

  void register_all(int min_inliers) {
    while (true) {
      int best = -1, best_count = 0;
      for (int f = 0; f < n_; ++f) {
        if (registered_[f]) continue;
        int count = 0;
        for (const auto& [t, k] : frame_obs_[f]) count += track_point_[t] >= 0 ? 1 : 0;
        // A frame that failed is retried only once it sees clearly more of the model.
        if (count < min_inliers || count <= failed_at_[f] * 1.2) continue;
        if (count > best_count) best = f, best_count = count;
      }
      if (best < 0) return;
      if (!register_frame(best, min_inliers)) {
        failed_at_[best] = best_count;
        log::debug("sfm: frame ", tracks_.frames[best].id, " not registered yet (", best_count, " 2D-3D)");
        continue;
      }
      registered_[best] = true;
      const int created = triangulate_frame(best);
      log::info("sfm: registered ", tracks_.frames[best].id, " (", registered_count(), "/", n_, "), ",
                created, " new points");
      if (registered_count() >= last_global_size_ * opt_.global_ba_growth) {
        global_round(true);
        retriangulate_all();
      } else {
        local_round(best);
      }
    }
  }

  // ---- output ----
  SfmResult result() const {
    SfmResult r;
    r.registered = registered_;
    r.initial_pair[0] = initial_pair_[0];
    r.initial_pair[1] = initial_pair_[1];
    r.track_point.assign(tracks_.tracks.size(), -1);
    r.frame_observations.assign(n_, 0);
    std::vector<double> sq(n_, 0);
    double total_sq = 0;
    std::size_t total = 0;
    for (const Point& point : points_) {
      if (!point.alive) continue;
      SfmPoint out;
      out.position = point.position;
      out.track = point.track;
      out.track_length = static_cast<int>(point.obs.size());
      double sum = 0;
      for (int k : point.obs) {
        const Obs& o = obs_[point.track][k];
        const double e = reprojection_error(o.frame, point.position, o.pixel);
        sum += e;
        sq[o.frame] += e * e;
        r.frame_observations[o.frame]++;
        total_sq += e * e;
        ++total;
      }
      out.reprojection_error_px = sum / point.obs.size();
      out.triangulation_angle_deg = max_angle(point.obs, point.track, point.position) / deg;
      r.track_point[point.track] = static_cast<int>(r.points.size());
      r.points.push_back(out);
    }
    r.rms_px = total ? std::sqrt(total_sq / total) : 0;
    r.principal_point_refined = principal_point_free_;
    for (int f = 0; f < n_; ++f) {
      Camera c = initial_[f];
      c.id = tracks_.frames[f].id;
      const IntrinsicParams& k = intr(f);
      c.intrinsics.fx = k[0];
      c.intrinsics.fy = k[0] * aspect(f);
      c.intrinsics.cx = k[1];
      c.intrinsics.cy = k[2];
      if (!beyond_radial2(c.distortion)) {
        c.distortion.k1 = k[3];
        c.distortion.k2 = k[4];
      }
      c.cam_from_world = rigid_from_params(poses_[f]);
      r.frame_rms_px.push_back(r.frame_observations[f] ? std::sqrt(sq[f] / r.frame_observations[f]) : 0);
      if (registered_[f]) {
        // Against the largest bound, not the adapted one: the same fit scores the same in every run.
        c.quality = std::clamp(1.0 - r.frame_rms_px[f] / opt_.max_reprojection_px, 0.0, 1.0) *
                    std::min(1.0, r.frame_observations[f] / 100.0);
      } else {
        r.unregistered.push_back(c.id);
      }
      r.cameras.push_back(c);
    }
    return r;
  }

  const TrackSet& tracks_;
  const std::vector<Camera>& initial_;
  SfmOptions opt_;
  int n_;
  std::vector<IntrinsicParams> intrinsics_;
  std::vector<double> aspect_;
  std::vector<int> group_;
  std::vector<std::vector<Obs>> obs_;                        // per track
  std::vector<std::vector<std::pair<int, int>>> frame_obs_;  // per frame: (track, observation index)
  std::vector<PoseParams> poses_;
  std::vector<bool> registered_;
  std::vector<int> failed_at_;
  std::vector<Point> points_;
  std::vector<Eigen::Vector3d> positions_;  // bundle adjustment scratch
  std::vector<int> track_point_;
  bool principal_point_free_ = false;
  int gauge_frame_ = -1;
  int initial_pair_[2] = {-1, -1};
  int last_global_size_ = 2;
  double bound_px_ = opt_.max_reprojection_px;  // the outlier bound now (adapt_bound)
  bool adapt_bound_ = false;
};

}  // namespace

SfmResult reconstruct(const TrackSet& tracks, const std::vector<Camera>& initial, const SfmOptions& options) {
  if (initial.size() != tracks.frames.size())
    throw UsageError(str("reconstruct: ", initial.size(), " cameras for ", tracks.frames.size(), " frames"));
  if (tracks.frames.size() < 2) throw UsageError("tracking needs at least 2 images");
  return Mapper(tracks, initial, options).run();
}

}  // namespace pg
