#include "pg/eval/eval_report.h"

#include "pg/core/atomic_file.h"
#include "pg/core/provenance.h"

namespace pg {

nlohmann::ordered_json eval_report(const std::string& kind, const std::filesystem::path& estimate,
                                   const std::filesystem::path& truth, const nlohmann::json& result) {
  nlohmann::ordered_json doc;
  doc["format"] = "pg-eval";
  doc["version"] = eval_report_version;
  doc["provenance"] = nlohmann::ordered_json::parse(to_json(Provenance::current()).dump());
  doc["evaluation"] = kind;
  doc["estimate"] = estimate.string();
  doc["truth"] = truth.string();
  doc["result"] = nlohmann::ordered_json::parse(result.dump());
  return doc;
}

void write_eval_report(const std::filesystem::path& path, const std::string& kind,
                       const std::filesystem::path& estimate, const std::filesystem::path& truth,
                       const nlohmann::json& result) {
  write_file_atomically(path, eval_report(kind, estimate, truth, result).dump(2) + "\n");
}

}  // namespace pg
