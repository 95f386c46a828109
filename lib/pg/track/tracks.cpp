#include "pg/track/tracks.h"

#include <cmath>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"

namespace pg {

std::vector<std::size_t> TrackSet::observations_per_frame() const {
  std::vector<std::size_t> counts(frames.size(), 0);
  for (const Track& track : tracks)
    for (const TrackObservation& o : track.observations)
      if (o.frame >= 0 && static_cast<std::size_t>(o.frame) < counts.size()) ++counts[o.frame];
  return counts;
}

namespace {

TrackFrame frame_from_json(const nlohmann::json& j, const std::filesystem::path& path, std::size_t index) {
  JsonReader r(j, path, str("frames[", index, "]"));
  for (const auto& [key, value] : j.items())
    if (key != "id" && key != "image" && key != "width" && key != "height")
      r.fail(str("unknown field '", key, "'"));
  TrackFrame frame;
  frame.id = r.string("id");
  frame.image = r.string_or("image", "");
  const long long width = r.integer("width"), height = r.integer("height");
  if (width < 1 || width > 65536 || height < 1 || height > 65536) r.fail("width/height outside [1, 65536]");
  frame.width = static_cast<int>(width);
  frame.height = static_cast<int>(height);
  return frame;
}

Track track_from_json(const nlohmann::json& j, const std::filesystem::path& path, std::size_t index,
                      const std::vector<TrackFrame>& frames) {
  JsonReader r(j, path, str("tracks[", index, "]"));
  for (const auto& [key, value] : j.items())
    if (key != "observations" && key != "point") r.fail(str("unknown field '", key, "'"));
  Track track;
  track.point = static_cast<int>(r.has("point") ? r.integer("point") : -1);
  if (track.point < -1) r.fail("point must be -1 or a point index");
  if (!j.is_object() || !j.contains("observations")) r.fail("a track needs its observations");
  const nlohmann::json& obs = j.at("observations");
  if (!obs.is_array() || obs.size() % 3 != 0) r.fail("observations must be an array of frame, x, y triples");
  const std::size_t count = obs.size() / 3;
  if (count < 2 || count > max_track_length)
    r.fail(str("a track needs 2 to ", max_track_length, " observations"));
  track.observations.reserve(count);
  std::vector<bool> seen(frames.size(), false);
  for (std::size_t k = 0; k < count; ++k) {
    const nlohmann::json &f = obs[3 * k], &x = obs[3 * k + 1], &y = obs[3 * k + 2];
    if (!f.is_number_integer() || !x.is_number() || !y.is_number()) r.fail("observations must be numbers");
    const long long frame = f.get<long long>();
    if (frame < 0 || static_cast<std::size_t>(frame) >= frames.size())
      r.fail(str("frame ", frame, " out of range"));
    if (seen[frame]) r.fail(str("frame ", frame, " observed twice"));
    seen[frame] = true;
    TrackObservation o{static_cast<int>(frame), x.get<float>(), y.get<float>()};
    const TrackFrame& tf = frames[frame];
    if (!std::isfinite(o.x) || !std::isfinite(o.y) || o.x < -0.5f || o.y < -0.5f || o.x > tf.width - 0.5f ||
        o.y > tf.height - 0.5f)
      r.fail(str("observation in frame ", frame, " is outside the image"));
    track.observations.push_back(o);
  }
  return track;
}

}  // namespace

TrackSet read_tracks(const std::filesystem::path& path) {
  const nlohmann::json doc = read_json_file(path);
  check_format_header(doc, path, tracks_format_name, tracks_format_version);
  JsonReader r(doc, path, "tracks file");
  for (const auto& [key, value] : doc.items())
    if (key != "format" && key != "version" && key != "provenance" && key != "method" && key != "frames" &&
        key != "tracks")
      r.fail(str("unknown field '", key, "'"));
  TrackSet set;
  if (doc.contains("provenance")) set.provenance = provenance_from_json(doc["provenance"]);
  set.method = r.string_or("method", "");
  const auto frames_it = doc.find("frames");
  const auto tracks_it = doc.find("tracks");
  if (frames_it == doc.end() || !frames_it->is_array()) r.fail("'frames' must be an array");
  if (tracks_it == doc.end() || !tracks_it->is_array()) r.fail("'tracks' must be an array");
  if (frames_it->size() < 1 || frames_it->size() > 1'000'000)
    r.fail("'frames' must hold 1 to 1000000 frames");
  if (tracks_it->size() > max_tracks) r.fail(str("more than ", max_tracks, " tracks"));
  for (std::size_t i = 0; i < frames_it->size(); ++i)
    set.frames.push_back(frame_from_json((*frames_it)[i], path, i));
  set.tracks.reserve(tracks_it->size());
  for (std::size_t i = 0; i < tracks_it->size(); ++i)
    set.tracks.push_back(track_from_json((*tracks_it)[i], path, i, set.frames));
  return set;
}

void write_tracks(const std::filesystem::path& path, const TrackSet& set) {
  nlohmann::ordered_json doc;
  doc["format"] = tracks_format_name;
  doc["version"] = tracks_format_version;
  doc["provenance"] = to_json(set.provenance.created_utc.empty() ? Provenance::current() : set.provenance);
  doc["method"] = set.method;
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const TrackFrame& f : set.frames)
    frames.push_back({{"id", f.id}, {"image", f.image}, {"width", f.width}, {"height", f.height}});
  doc["frames"] = std::move(frames);
  // One track per line keeps the file readable and diffable; the header is indented as usual.
  std::string text = doc.dump(2);
  text.resize(text.size() - 2);  // drop "\n}"
  text += ",\n  \"tracks\": [";
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    const Track& t = set.tracks[i];
    nlohmann::ordered_json obs = nlohmann::ordered_json::array();
    for (const TrackObservation& o : t.observations) {
      obs.push_back(o.frame);
      obs.push_back(o.x);
      obs.push_back(o.y);
    }
    nlohmann::ordered_json track;
    if (t.point >= 0) track["point"] = t.point;
    track["observations"] = std::move(obs);
    text += (i == 0 ? "\n    " : ",\n    ") + track.dump();
  }
  text += set.tracks.empty() ? "]\n}\n" : "\n  ]\n}\n";
  write_file_atomically(path, text);
}

}  // namespace pg
