#include "pg/refine/brush_strokes.h"

#include <cmath>

#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"

namespace pg {
namespace {

BrushStroke stroke_from_json(const JsonReader& r) {
  BrushStroke s;
  for (const auto& [key, value] : r.node().items())
    if (key != "mode" && key != "space" && key != "view" && key != "points" && key != "radius" &&
        key != "strength" && key != "falloff")
      r.fail("unknown field '" + key + "'");
  try {
    s.mode = brush_mode_from_string(r.string_or("mode", "paint"));
    s.falloff = brush_falloff_from_string(r.string_or("falloff", "smooth"));
  } catch (const UsageError& e) {
    r.fail(e.what());
  }
  const std::string space = r.string("space");
  if (space != "world" && space != "screen")
    r.fail("space must be \"world\" or \"screen\", not \"" + space + "\"");
  s.screen = space == "screen";
  if (s.screen) {
    s.view = r.string("view");
    if (s.view.empty()) r.fail("a screen stroke needs the id of its view");
  } else if (r.has("view")) {
    r.fail("a world stroke has no view");
  }
  s.radius = r.number("radius");
  if (!(s.radius > 0) || !std::isfinite(s.radius)) r.fail("radius must be a finite number > 0");
  s.strength = r.number_or("strength", 1.0);
  if (!(s.strength >= 0 && s.strength <= 1)) r.fail("strength must be in [0, 1]");
  if (!r.node().contains("points") || !r.node()["points"].is_array()) r.fail("points must be an array");
  const auto& points = r.node()["points"];
  if (points.empty()) r.fail("points is empty");
  if (points.size() > max_stroke_points) r.fail(str("more than ", max_stroke_points, " points"));
  const std::size_t dimension = s.screen ? 2 : 3;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    if (!p.is_array() || p.size() != dimension)
      r.fail(str("points[", i, "] must be ", dimension, " numbers (",
                 s.screen ? "pixel x, y" : "world x, y, z", ")"));
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    for (std::size_t c = 0; c < dimension; ++c) {
      if (!p[c].is_number() || !std::isfinite(p[c].get<double>()))
        r.fail(str("points[", i, "] is not finite numbers"));
      point[int(c)] = p[c].get<double>();
    }
    s.points.push_back(point);
  }
  return s;
}

}  // namespace

BrushStrokes read_brush_strokes(const std::filesystem::path& path) {
  const nlohmann::json doc = read_json_file(path);
  check_format_header(doc, path, brush_strokes_format_name, brush_strokes_format_version);
  JsonReader root(doc, path, "");
  BrushStrokes result;
  if (doc.contains("provenance")) result.provenance = provenance_from_json(doc["provenance"]);
  if (!doc.contains("strokes") || !doc["strokes"].is_array()) root.fail("strokes must be an array");
  const auto& strokes = doc["strokes"];
  if (strokes.size() > max_brush_strokes) root.fail(str("more than ", max_brush_strokes, " strokes"));
  for (std::size_t i = 0; i < strokes.size(); ++i) {
    if (!strokes[i].is_object()) root.fail(str("strokes[", i, "] must be an object"));
    result.strokes.push_back(stroke_from_json(JsonReader(strokes[i], path, str("strokes[", i, "]"))));
  }
  return result;
}

nlohmann::ordered_json brush_strokes_to_json(const BrushStrokes& strokes) {
  const Provenance provenance =
      strokes.provenance.created_utc.empty() ? Provenance::current() : strokes.provenance;
  nlohmann::ordered_json doc;
  doc["format"] = brush_strokes_format_name;
  doc["version"] = brush_strokes_format_version;
  doc["provenance"] = to_json(provenance);
  doc["strokes"] = nlohmann::ordered_json::array();
  for (const auto& s : strokes.strokes) {
    nlohmann::ordered_json j;
    j["mode"] = to_string(s.mode);
    j["space"] = s.screen ? "screen" : "world";
    if (s.screen) j["view"] = s.view;
    j["radius"] = s.radius;
    j["strength"] = s.strength;
    j["falloff"] = to_string(s.falloff);
    j["points"] = nlohmann::ordered_json::array();
    for (const auto& p : s.points) {
      if (s.screen)
        j["points"].push_back({p.x(), p.y()});
      else
        j["points"].push_back({p.x(), p.y(), p.z()});
    }
    doc["strokes"].push_back(std::move(j));
  }
  return doc;
}

void write_brush_strokes(const std::filesystem::path& path, const BrushStrokes& strokes) {
  write_json_file(path, brush_strokes_to_json(strokes));
}

}  // namespace pg
