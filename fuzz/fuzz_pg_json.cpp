// Fuzz target: the generic pg JSON path every JSON reader starts with (run reports, calibration and
// eval reports): parse, check the format header, read the provenance.
#include "fuzz_input.h"
#include "pg/core/json_file.h"
#include "pg/core/provenance.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pg::fuzz::write_scratch(data, size, ".json");
  pg::fuzz::read_accepting_input_errors(path, [](const auto& p) {
    const nlohmann::json doc = pg::read_json_file(p);
    pg::check_format_header(doc, p, "pg-run-report", 1);
    const pg::JsonReader reader(doc, p, "report");
    if (reader.has("provenance")) pg::provenance_from_json(reader.child("provenance").node());
  });
  return 0;
}
