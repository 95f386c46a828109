#pragma once
// Agreement of feature tracks with a set of cameras (the true ones, typically): every track is
// triangulated with the cameras of its frames, and each observation's distance to the projection of
// that point is its error. It measures how well the tracks locate the same surface point in every
// frame, independently of any reconstruction: with exact cameras, a perfectly localised track has
// zero error.
#include <vector>

#include "pg/camera/camera.h"
#include "pg/eval/stats.h"
#include "pg/track/tracks.h"

namespace pg {

struct TrackAgreement {
  ErrorStats observation_error_px;  // over the observations of the tracks used
  // Per track used: the mean of its observations' errors (a point's own accuracy).
  ErrorStats track_error_px;
  std::size_t tracks_used = 0;  // triangulated in front of every camera
};

// `cameras[f]` is frame f of `tracks`. Tracks that do not triangulate (parallel rays, behind a
// camera) are left out. Throws UsageError when a track names a frame without a camera.
TrackAgreement track_agreement(const TrackSet& tracks, const std::vector<Camera>& cameras);

}  // namespace pg
