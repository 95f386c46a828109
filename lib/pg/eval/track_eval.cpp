#include "pg/eval/track_eval.h"

#include <tbb/parallel_for.h>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/geometry/triangulation.h"

namespace pg {

TrackAgreement track_agreement(const TrackSet& tracks, const std::vector<Camera>& cameras) {
  for (const Track& t : tracks.tracks)
    for (const TrackObservation& o : t.observations)
      if (o.frame < 0 || o.frame >= static_cast<int>(cameras.size()))
        throw UsageError(
            str("a track observes frame ", o.frame, " but there are ", cameras.size(), " cameras"));
  std::vector<std::vector<double>> errors(tracks.tracks.size());
  tbb::parallel_for(std::size_t(0), tracks.tracks.size(), [&](std::size_t k) {
    const Track& track = tracks.tracks[k];
    std::vector<Rigid3> poses;
    std::vector<Eigen::Vector3d> rays;
    for (const TrackObservation& o : track.observations) {
      poses.push_back(cameras[o.frame].cam_from_world);
      rays.push_back(cameras[o.frame].unproject(Eigen::Vector2d(o.x, o.y)));
    }
    const auto point = triangulate(poses, rays);
    if (!point) return;
    std::vector<double> e;
    for (const TrackObservation& o : track.observations) {
      Eigen::Vector2d pixel;
      if (!cameras[o.frame].project_world(*point, pixel)) return;
      e.push_back((pixel - Eigen::Vector2d(o.x, o.y)).norm());
    }
    errors[k] = std::move(e);
  });
  std::vector<double> observation_errors, track_errors;
  for (const std::vector<double>& e : errors) {
    if (e.empty()) continue;
    double sum = 0;
    for (double x : e) sum += x, observation_errors.push_back(x);
    track_errors.push_back(sum / e.size());
  }
  TrackAgreement out;
  out.tracks_used = track_errors.size();
  out.observation_error_px = summarize(observation_errors);
  out.track_error_px = summarize(track_errors);
  return out;
}

}  // namespace pg
