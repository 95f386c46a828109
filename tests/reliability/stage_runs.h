#pragma once
// The stage tools run on small synthetic inputs (pg-synth at 160 x 120), shared by the
// kill-safety, determinism and memory-limit tests: one command per stage writing into an out folder.
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace pg::reliability {

struct StageRun {
  std::string name;  // the test parameter: "depth", "merge", ...
  std::string tool;  // "pg-depth"
  // The arguments writing every output into `out` (an existing, maybe non-empty folder).
  std::vector<std::string> (*args)(const std::filesystem::path& inputs, const std::filesystem::path& out);
};

// gtest prints the stage by name in test failures.
inline void PrintTo(const StageRun& run, std::ostream* os) {
  *os << run.name;
}

// Every stage tool; the inputs they read are made on first use by scene().
const std::vector<StageRun>& stage_runs();

// The folder holding the synthetic input scenes of this process.
const std::filesystem::path& shared_inputs();

// The pg-synth scene "set", "deform", "orbit", "room" or "board" under shared_inputs(), rendered on
// first use.
std::filesystem::path scene(const std::string& name);

// Runs the stage into `out` with the extra common flags; returns the exit code.
int run_stage(const StageRun& stage, const std::filesystem::path& out, const std::vector<std::string>& extra,
              std::string* stderr_text = nullptr);

// Runs the stage into `dir / "run"` and renames that folder to `dir / name`: every run writes under the
// same paths, which some outputs record (remesh.json names its input and output).
int run_stage_as(const StageRun& stage, const std::filesystem::path& dir, const std::string& name,
                 const std::vector<std::string>& extra, std::string* stderr_text = nullptr);

// The output files under `out` under their final names (atomic-write temporaries excluded), sorted.
std::vector<std::filesystem::path> final_outputs(const std::filesystem::path& out);

// `pg-info digest` of every final output, keyed by the path relative to `out`.
std::map<std::string, std::string> output_digests(const std::filesystem::path& out);

// Whether `pg-info validate` can read the file (formats it knows: JSON, PLY, OBJ, EXR, VDB, FLO, images).
bool validatable(const std::filesystem::path& file);

}  // namespace pg::reliability
