#pragma once
// Feature tracks across the frames of a sequence and the tracks file (formats/tracks.md):
// format "pg-tracks", version 1.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pg/core/provenance.h"

namespace pg {

inline constexpr const char* tracks_format_name = "pg-tracks";
inline constexpr int tracks_format_version = 1;
// Readers refuse files claiming more than this many tracks or observations (before allocating).
inline constexpr std::size_t max_tracks = 50'000'000;
inline constexpr std::size_t max_track_length = 100'000;

// One sighting of a track: frame index and pixel position (pixel (0, 0) is the centre of the
// top-left pixel, in the frame's full-resolution image).
struct TrackObservation {
  int frame = 0;
  float x = 0, y = 0;
};

struct Track {
  std::vector<TrackObservation> observations;  // at most one per frame, in frame order
  int point = -1;  // index of the reconstructed point in the sparse points file, -1 when none
};

struct TrackFrame {
  std::string id;     // camera id (the image file's stem)
  std::string image;  // image path as given to the tracker
  int width = 0, height = 0;
};

struct TrackSet {
  std::vector<TrackFrame> frames;
  std::vector<Track> tracks;
  std::string method;  // "sift", "klt", "shi-tomasi" (with "+sift" when loops were matched by SIFT)
  Provenance provenance;

  // Observations per frame (for statistics and the report).
  std::vector<std::size_t> observations_per_frame() const;
};

// Throws InputError(path, ...) for a wrong format or version, missing or unknown fields, a frame
// index out of range, a frame seen twice in one track, a track shorter than 2, non-finite or
// out-of-image positions, or counts above the bounds above.
TrackSet read_tracks(const std::filesystem::path& path);
// Writes atomically, with Provenance::current() when the set's provenance was never filled.
void write_tracks(const std::filesystem::path& path, const TrackSet& set);

}  // namespace pg
