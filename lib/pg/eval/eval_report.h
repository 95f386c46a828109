#pragma once
// The pg-eval result file (formats/eval-report.md): format "pg-eval", version 1, provenance, which
// evaluation ran on which files, and the evaluation's own JSON.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace pg {

inline constexpr int eval_report_version = 1;

// {"format": "pg-eval", "version": 1, "provenance": current, "evaluation": kind,
//  "estimate": estimate, "truth": truth, "result": result}
// Ordered, so that format, version and provenance come first in the file.
nlohmann::ordered_json eval_report(const std::string& kind, const std::filesystem::path& estimate,
                                   const std::filesystem::path& truth, const nlohmann::json& result);

// Writes eval_report(...) atomically.
void write_eval_report(const std::filesystem::path& path, const std::string& kind,
                       const std::filesystem::path& estimate, const std::filesystem::path& truth,
                       const nlohmann::json& result);

}  // namespace pg
