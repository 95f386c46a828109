#pragma once
// The brush strokes file (formats/brush-strokes.md): format "pg-brush-strokes", version 1.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "pg/core/provenance.h"
#include "pg/refine/brush.h"

namespace pg {

inline constexpr const char* brush_strokes_format_name = "pg-brush-strokes";
inline constexpr int brush_strokes_format_version = 1;
inline constexpr std::size_t max_brush_strokes = 100000;
inline constexpr std::size_t max_stroke_points = 100000;

struct BrushStrokes {
  std::vector<BrushStroke> strokes;  // applied in order
  Provenance provenance;
};

// Throws InputError(path, ...) naming the stroke and field at fault: wrong format or version,
// unknown mode, space or falloff, a screen stroke without a view, points of the wrong dimension or
// not finite, radius <= 0, strength outside [0, 1], more strokes or points than the limits above.
BrushStrokes read_brush_strokes(const std::filesystem::path& path);
// Writes atomically (provenance: Provenance::current() when never filled).
void write_brush_strokes(const std::filesystem::path& path, const BrushStrokes& strokes);
nlohmann::ordered_json brush_strokes_to_json(const BrushStrokes& strokes);

}  // namespace pg
