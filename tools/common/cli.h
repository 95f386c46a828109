#pragma once
// The shared frame of every pg-* tool: common flags, logging, threads, progress, the run report,
// exit codes and the input/output rules (inputs must exist; outputs never overwrite an input and are
// written atomically by the library writers). A tool's main is:
//
//   int main(int argc, char** argv) {
//     pg::cli::Frame frame({"pg-x", "one-line summary", "pg-x --in a.exr --out b.ply"});
//     Options o;  frame.app().add_option("--in", o.in)->required();  ...
//     return frame.run(argc, argv, [&] { frame.input(o.in); frame.output(o.out); ... });
//   }
#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace pg::cli {

struct ToolInfo {
  std::string name;     // "pg-synth"
  std::string summary;  // one line
  std::string example;  // one or more worked command lines, shown by --help
};

class Frame {
 public:
  explicit Frame(ToolInfo info);

  CLI::App& app() { return app_; }
  std::uint64_t seed() const { return seed_; }
  int threads() const { return threads_; }
  // The --max-memory budget in bytes; 0 = no limit. Also readable anywhere through memory_budget().
  std::uint64_t max_memory() const { return max_memory_; }

  // Declares an input file: it must exist (InputError otherwise) and not be a declared output
  // (OutputError); recorded in the report/provenance.
  void input(const std::filesystem::path& path);
  // Declares an input folder.
  void input_dir(const std::filesystem::path& path);
  // Declares a file the run names but does not read (another farm chunk's input): outputs may not
  // overwrite it, but it need not exist and is not recorded as an input.
  void keep(const std::filesystem::path& path);
  // Declares an output file: refused (OutputError) if it is one of the declared inputs or outputs
  // (the --report file included), or its folder is missing; recorded in the report.
  void output(const std::filesystem::path& path);
  // Declares an output folder, created if missing; refused if it is a declared input folder.
  void output_dir(const std::filesystem::path& path);

  // Parses, applies the common flags, runs body and maps exceptions to exit codes.
  int run(int argc, char** argv, const std::function<void()>& body);

 private:
  ToolInfo info_;
  CLI::App app_;
  std::string log_level_ = "info";
  std::string progress_mode_ = "auto";
  std::string report_path_;
  std::string device_ = "auto";
  std::uint64_t seed_ = 1;
  int threads_ = 0;
  std::string max_memory_text_;
  std::uint64_t max_memory_ = 0;
  void refuse_declared_output(const std::filesystem::path& input) const;

  std::vector<std::filesystem::path> inputs_;  // and the kept files (keep)
  std::vector<std::filesystem::path> outputs_;
  std::vector<std::filesystem::path> input_dirs_;
};

std::string exit_code_help();

// Option checks whose messages read "must be greater than 0, got -3" (CLI11's PositiveNumber and
// NonNegativeNumber print the largest double as the range's end).
CLI::Validator positive();
CLI::Validator non_negative();

// "8G", "512M", "64K" or a byte count -> bytes; UsageError naming --max-memory otherwise.
std::uint64_t parse_memory_size(const std::string& text);

// The process's --max-memory budget in bytes (0 = no limit), set by Frame::run.
std::uint64_t memory_budget();

// Fails early with Error(out_of_memory) (exit code 5, which a farm retries on a bigger node) when
// `bytes`, a stage's estimate of what it is about to allocate for `what`, exceeds the budget.
void require_memory(std::uint64_t bytes, const std::string& what);

}  // namespace pg::cli
