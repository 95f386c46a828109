#pragma once
// What pg-track writes besides the tracks: registered cameras, the sparse points PLY (colour, track
// length, reprojection error, triangulation angle), a top view of the camera path and points, and
// the metric scale from a known distance between two cameras.
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "pg/camera/cameras_io.h"
#include "pg/sfm/reconstruction.h"
#include "pg/track/tracks.h"

namespace pg {

// The registered cameras (unregistered frames are left out).
CameraSet registered_cameras(const SfmResult& result);

// Colours every point from one of its observations in the frames' images (tracks.frames[].image).
void color_points(SfmResult& result, const TrackSet& tracks);

// x y z, red green blue, track_length, reprojection_error (px), triangulation_angle (degrees); a
// "pg-point-cloud" PLY readable by read_point_cloud_ply.
void write_sparse_points(const std::filesystem::path& path, const SfmResult& result);

// Points and camera centres seen from above: the view looks along the normal of the plane that best
// fits the camera centres (the ground of an orbit or a walk). Cameras are coloured by their
// reprojection RMS from green (0 px) to red (max_rms_px and above); unregistered frames are listed
// in red text.
cv::Mat render_top_view(const SfmResult& result, int size = 800, double max_rms_px = 2.0);

// Scales the reconstruction so that cameras `id_a` and `id_b` are `distance` apart. Throws UsageError
// when an id is unknown or the distance is not positive, FailedError when a camera was not registered
// or the two centres coincide. Returns the scale applied.
double scale_to_distance(SfmResult& result, const std::string& id_a, const std::string& id_b,
                         double distance);

// Multiplies every length of the reconstruction (camera centres, points) by `s`.
void scale_reconstruction(SfmResult& result, double s);

}  // namespace pg
