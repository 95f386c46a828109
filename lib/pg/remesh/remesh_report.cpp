#include "pg/remesh/remesh_report.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/log.h"
#include "pg/core/provenance.h"
#include "pg/remesh/region.h"

namespace pg {
namespace {

constexpr const char* format_name = "pg-remesh-report";
constexpr int format_version = 1;

// Histogram counts as fractions of their total, so before and after compare at any mesh size.
std::vector<double> fractions(const Histogram& h) {
  const double total = std::max<double>(1, double(h.total()));
  std::vector<double> f;
  for (std::size_t c : h.counts) f.push_back(double(c) / total);
  return f;
}

void draw_panel(cv::Mat3b& image, const cv::Rect& area, const std::string& title, const Histogram& before,
                const Histogram& after, const std::vector<std::string>& labels) {
  const cv::Scalar black(0, 0, 0), grey(160, 160, 160), blue(200, 90, 20);
  cv::putText(image, title, {area.x + 8, area.y + 22}, cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1, cv::LINE_AA);
  const cv::Rect plot(area.x + 10, area.y + 36, area.width - 20, area.height - 70);
  cv::rectangle(image, plot, black, 1);
  const std::vector<double> b = fractions(before), a = fractions(after);
  const double top =
      std::max(0.01, std::max(*std::max_element(b.begin(), b.end()), *std::max_element(a.begin(), a.end())));
  const double bin = double(plot.width) / double(b.size());
  for (std::size_t i = 0; i < b.size(); ++i) {
    const int x0 = plot.x + int(i * bin), half = std::max(1, int(bin / 2) - 1);
    const auto bar = [&](int x, double value, const cv::Scalar& colour) {
      const int h = int(value / top * (plot.height - 4));
      if (h > 0) cv::rectangle(image, cv::Rect(x, plot.y + plot.height - h, half, h), colour, cv::FILLED);
    };
    bar(x0 + 1, b[i], grey);
    bar(x0 + 1 + half, a[i], blue);
    if (i < labels.size() && !labels[i].empty())
      cv::putText(image, labels[i], {x0, plot.y + plot.height + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.38, black, 1,
                  cv::LINE_AA);
  }
  cv::putText(image, "before", {plot.x + plot.width - 120, plot.y + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.45, grey,
              1, cv::LINE_AA);
  cv::putText(image, "after", {plot.x + plot.width - 60, plot.y + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.45, blue,
              1, cv::LINE_AA);
}

std::vector<std::string> bin_labels(const Histogram& h, int every, const std::string& last_suffix = "") {
  std::vector<std::string> labels(h.counts.size());
  const double width = (h.hi - h.lo) / double(h.counts.size());
  for (std::size_t i = 0; i < labels.size(); i += every) labels[i] = str(h.lo + double(i) * width);
  if (!last_suffix.empty()) labels.back() = str(h.lo + double(labels.size() - 1) * width) + last_suffix;
  return labels;
}

}  // namespace

RemeshEvaluation evaluate_remesh(const RemeshResult& r) {
  RemeshEvaluation e;
  e.before = measure_quality(r.input, r.input_in_region, r.input_target);
  e.after = measure_quality(r.mesh, r.in_region, r.target);
  const std::vector<bool> input_faces = faces_touching(r.input, r.input_in_region);
  const float spacing = 0.25f * r.target_length;
  e.hausdorff =
      hausdorff_distance(r.mesh, faces_touching(r.mesh, r.in_region), r.input, input_faces, spacing);
  e.smooth_hausdorff = smooth_region_hausdorff(r.mesh, r.input, input_faces, r.target_length, 3, spacing);
  return e;
}

nlohmann::ordered_json remesh_report_json(const RemeshResult& r, const RemeshOptions& o,
                                          const RemeshEvaluation& e, const RemeshReportFiles& files) {
  const RemeshStats& s = r.stats;
  nlohmann::ordered_json doc;
  doc["format"] = format_name;
  doc["version"] = format_version;
  doc["provenance"] = to_json(Provenance::current());
  doc["input"] = files.input;
  doc["output"] = files.output;
  doc["options"] = {{"target_length", r.target_length},
                    {"target_length_given", o.target_length > 0},
                    {"iterations", o.iterations},
                    {"feature_angle_deg", o.feature_angle_deg},
                    {"adaptive", o.adaptive}};
  doc["region"] = {{"source", files.region},
                   {"vertices", s.region_vertices},
                   {"pinned_vertices", s.pinned_vertices},
                   {"feature_edges", s.feature_edges},
                   {"corner_vertices", s.corner_vertices}};
  doc["counts"] = {{"input_vertices", r.input.vertex_count() + s.unused_vertices_dropped},
                   {"input_faces", r.input.face_count()},
                   {"unused_vertices_dropped", s.unused_vertices_dropped},
                   {"output_vertices", r.mesh.vertex_count()},
                   {"output_faces", r.mesh.face_count()},
                   {"splits", s.splits},
                   {"collapses", s.collapses},
                   {"flips", s.flips}};
  doc["quality"] = {{"before", e.before.to_json()}, {"after", e.after.to_json()}};
  doc["hausdorff"] = {{"distance", e.hausdorff.distance},
                      {"relative_to_target", e.hausdorff.distance / r.target_length},
                      {"output_to_input", e.hausdorff.a_to_b},
                      {"input_to_output", e.hausdorff.b_to_a},
                      {"samples", e.hausdorff.samples}};
  const SmoothRegionHausdorff& smooth = e.smooth_hausdorff;
  doc["hausdorff_smooth"] = {{"radius_factor", smooth.radius_factor},
                             {"input_fraction", smooth.input_fraction},
                             {"distance", smooth.hausdorff.distance},
                             {"relative_to_target", smooth.hausdorff.distance / r.target_length},
                             {"output_to_input", smooth.hausdorff.a_to_b},
                             {"input_to_output", smooth.hausdorff.b_to_a},
                             {"samples", smooth.hausdorff.samples}};
  doc["masks_written"] = files.masks_written;
  return doc;
}

void write_remesh_report(const std::filesystem::path& path, const nlohmann::ordered_json& report) {
  write_json_file(path, report);
}

void write_quality_png(const std::filesystem::path& path, const RemeshEvaluation& e) {
  const int panel_width = 420, height = 300;
  cv::Mat3b image(height, 3 * panel_width, cv::Vec3b(255, 255, 255));
  draw_panel(image, {0, 0, panel_width, height}, "edge length / target", e.before.edge_ratio,
             e.after.edge_ratio, bin_labels(e.before.edge_ratio, 4, "+"));
  draw_panel(image, {panel_width, 0, panel_width, height}, "minimum angle (degrees)", e.before.min_angle_deg,
             e.after.min_angle_deg, bin_labels(e.before.min_angle_deg, 2));
  draw_panel(image, {2 * panel_width, 0, panel_width, height}, "valence (interior vertices)",
             e.before.valence, e.after.valence, bin_labels(e.before.valence, 1, "+"));
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    if (!cv::imwrite(tmp.string(), image)) throw OutputError(path, "cannot write the PNG");
  });
}

}  // namespace pg
