#pragma once
// The remeshing report (formats/remesh-report.md): quality of the region before and after, the
// Hausdorff distance to the input, what was kept, and a PNG of the quality histograms.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pg/remesh/quality.h"
#include "pg/remesh/remesh.h"

namespace pg {

struct RemeshEvaluation {
  MeshQuality before;  // the input's region (faces with three region vertices)
  MeshQuality after;   // the output's region
  // Between the faces touching the region (region and seam) of output and input; samples at most
  // L / 4 apart.
  HausdorffDistance hausdorff;
  // The same where the input region is smooth at scale L (smooth_region_hausdorff, radius factor 3).
  SmoothRegionHausdorff smooth_hausdorff;
};
RemeshEvaluation evaluate_remesh(const RemeshResult& result);

struct RemeshReportFiles {
  std::string input, output;
  std::string region;  // how the region was chosen: "whole mesh", "mask FILE", "deformed from FILE ..."
  std::vector<std::string> masks_written;
};

nlohmann::ordered_json remesh_report_json(const RemeshResult& result, const RemeshOptions& options,
                                          const RemeshEvaluation& evaluation, const RemeshReportFiles& files);
void write_remesh_report(const std::filesystem::path& path, const nlohmann::ordered_json& report);

// Three panels (edge length / target, minimum angle, valence), before in grey and after in blue.
void write_quality_png(const std::filesystem::path& path, const RemeshEvaluation& evaluation);

}  // namespace pg
