#include "common/cli.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <new>

#include "pg/build_info.h"
#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/core/parallel.h"
#include "pg/core/progress.h"
#include "pg/core/provenance.h"
#include "pg/core/run_report.h"
#include "pg/gpu/device.h"
#include "pg/image/huge_page_mats.h"

namespace fs = std::filesystem;

namespace pg::cli {
namespace {

void on_signal(int) {
  remove_temporaries_in_flight();
  static const char message[] = "pg: interrupted\n";
  [[maybe_unused]] auto n = ::write(STDERR_FILENO, message, sizeof message - 1);
  ::_exit(int(ExitCode::interrupted));
}

// What the terminate handler prints for a std::bad_alloc, composed before the body runs because the
// handler must not allocate.
char out_of_memory_line[256] = "pg: error: out of memory\n";
std::terminate_handler previous_terminate = nullptr;

// A std::bad_alloc thrown from a destructor while an earlier one unwinds (OpenVDB's Tree::clear
// gathers nodes into vectors to free them) ends in std::terminate instead of run's catch. It is
// still exit code 5 (a farm retries on a bigger node), and no temporary output is left behind.
[[noreturn]] void on_terminate() {
  bool out_of_memory = false;
  if (std::current_exception()) {
    try {
      throw;  // the exception being handled, without allocating (rethrow_exception may)
    } catch (const std::bad_alloc&) {
      out_of_memory = true;
    } catch (...) {
    }
  }
  remove_temporaries_in_flight();
  if (out_of_memory) {
    [[maybe_unused]] auto n = ::write(STDERR_FILENO, out_of_memory_line, std::strlen(out_of_memory_line));
    ::_exit(int(ExitCode::out_of_memory));
  }
  if (previous_terminate) previous_terminate();
  std::abort();
}

std::string quote_arg(const std::string& a) {
  if (!a.empty() && a.find_first_of(" \t\"'$\\") == std::string::npos) return a;
  std::string q = "'";
  for (char c : a) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::uint64_t budget_bytes = 0;

std::string out_of_memory_message() {
  return budget_bytes
             ? str("out of memory: an allocation went past --max-memory ", budget_bytes >> 20, " MiB")
             : std::string("out of memory");
}

// Builds with AddressSanitizer reserve terabytes of address space, so no address-space limit there.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool address_space_limit_possible = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool address_space_limit_possible = false;
#else
constexpr bool address_space_limit_possible = true;
#endif
#else
constexpr bool address_space_limit_possible = true;
#endif

std::uint64_t address_space_in_use() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t pages = 0;
  statm >> pages;
  return pages * std::uint64_t(::sysconf(_SC_PAGESIZE));
}

// The backstop behind the stages' own estimates (require_memory): an address-space limit of what is
// mapped now plus the budget, so an allocation past it fails with std::bad_alloc (exit code 5)
// instead of the kernel killing the job. Each worker thread may map a stack and a malloc arena
// (8 + 64 MiB) without using them; that reservation is added so it does not count as use.
void limit_address_space(std::uint64_t budget, int threads) {
  if (!address_space_limit_possible || budget == 0) return;
  const std::uint64_t per_thread_reserve = std::uint64_t{72} << 20;
  const int workers = threads > 0 ? threads : int(::sysconf(_SC_NPROCESSORS_ONLN));
  const rlim_t limit = address_space_in_use() + budget + per_thread_reserve * std::uint64_t(workers + 1);
  rlimit current{};
  if (::getrlimit(RLIMIT_AS, &current) != 0) return;
  if (current.rlim_max != RLIM_INFINITY && limit > current.rlim_max) return;
  current.rlim_cur = limit;
  ::setrlimit(RLIMIT_AS, &current);
}

bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

}  // namespace

std::string exit_code_help() {
  return "Exit codes: 0 ok, 1 internal error, 2 bad usage, 3 bad or unreadable input, 4 computation "
         "failed, 5 out of memory, 6 output not writable or would overwrite an input, 130 interrupted.";
}

namespace {

// A validator for a number that `accept` takes, `wanted` saying what it must be otherwise.
CLI::Validator number_check(const std::function<bool(double)>& accept, const std::string& wanted,
                            const std::string& name) {
  return CLI::Validator(
      [accept, wanted](std::string& text) -> std::string {
        double value = 0;
        std::size_t used = 0;
        try {
          value = std::stod(text, &used);
        } catch (const std::logic_error&) {
          return "\"" + text + "\" is not a number";
        }
        if (used != text.size()) return "\"" + text + "\" is not a number";
        return accept(value) ? std::string() : "must be " + wanted + ", got " + text;
      },
      name, name);
}

}  // namespace

CLI::Validator positive() {
  return number_check([](double v) { return v > 0 && std::isfinite(v); }, "greater than 0", "POSITIVE");
}

CLI::Validator non_negative() {
  return number_check([](double v) { return v >= 0 && std::isfinite(v); }, "0 or more", "NON-NEGATIVE");
}

std::uint64_t parse_memory_size(const std::string& text) {
  const std::string problem = str("--max-memory '", text, "' is not a size such as 8G, 512M or 1000000");
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::logic_error&) {
    throw UsageError(problem);
  }
  const std::string unit = text.substr(used);
  const double scale = unit.empty()  ? 1.0
                       : unit == "K" ? double(1 << 10)
                       : unit == "M" ? double(1 << 20)
                       : unit == "G" ? double(1 << 30)
                                     : -1.0;
  if (scale < 0 || !(value > 0) || value * scale > 1e18) throw UsageError(problem);
  return std::uint64_t(value * scale);
}

std::uint64_t memory_budget() {
  return budget_bytes;
}

void require_memory(std::uint64_t bytes, const std::string& what) {
  if (budget_bytes == 0 || bytes <= budget_bytes) return;
  throw Error(ExitCode::out_of_memory,
              str(what, " needs ", bytes >> 20, " MiB, more than --max-memory ", budget_bytes >> 20, " MiB"));
}

Frame::Frame(ToolInfo info) : info_(std::move(info)), app_(info_.summary, info_.name) {
  app_.set_version_flag("--version", std::string(info_.name) + " " + build_info::version);
  app_.add_option("--log-level", log_level_, "error, warn, info, debug or trace")->capture_default_str();
  app_.add_option("--threads", threads_, "worker threads (0 = all cores); results do not depend on it")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app_.add_option("--seed", seed_, "seed for every random choice; same inputs and seed, same outputs")
      ->capture_default_str();
  app_.add_option("--max-memory", max_memory_text_,
                  "memory budget such as 8G or 512M: fail early with exit code 5 rather than exceed it");
  app_.add_option("--report", report_path_, "write the run report (JSON: metrics, timings, memory) here");
  app_.add_option("--progress", progress_mode_,
                  "progress lines on stderr: auto (redraw on a terminal, lines otherwise), lines, off")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "lines", "off"}));
  app_.add_option("--device", device_,
                  "where accelerated stages run (the flow solver of pg-depth, pg-sphdepth and pg-refine, "
                  "pg-refine's rasterizer, pg-merge's TSDF integration): cpu, opencl, cuda or auto (a GPU "
                  "when one is usable); falls back to the CPU with a notice")
      ->capture_default_str()
      ->check(CLI::IsMember({"cpu", "opencl", "cuda", "auto"}));
  app_.footer("Example:\n" + info_.example + "\n\n" + exit_code_help());
  app_.fallthrough();  // the common flags also work after a subcommand: `pg-x run --threads 2`
}

// An input declared after the outputs (or the --report file) is checked against them, so the order
// in which a tool declares its files does not decide whether an input can be overwritten.
void Frame::refuse_declared_output(const fs::path& input) const {
  for (const auto& out : outputs_)
    if (same_file(out, input)) throw OutputError(out, "refusing to overwrite an input of this run");
}

void Frame::input(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "no such file");
  if (fs::is_directory(path, ec)) throw InputError(path, "is a folder, expected a file");
  inputs_.push_back(path);  // first, so that a refused --report is not written over it either
  refuse_declared_output(path);
  RunReport::global().add_input(path);
  Provenance::add_current_input(path.string());
}

void Frame::input_dir(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) throw InputError(path, "no such folder");
  input_dirs_.push_back(path);
  RunReport::global().add_input(path);
  Provenance::add_current_input(path.string());
}

void Frame::keep(const fs::path& path) {
  inputs_.push_back(path);
  refuse_declared_output(path);
}

void Frame::output(const fs::path& path) {
  for (const auto& in : inputs_)
    if (same_file(in, path)) throw OutputError(path, "refusing to overwrite an input of this run");
  for (const auto& out : outputs_)
    if (same_file(out, path))
      throw OutputError(path, "named for two outputs of this run; one would replace the other");
  fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw OutputError(path, "output folder does not exist");
  if (fs::is_directory(path, ec)) throw OutputError(path, "is a folder, expected a file name");
  outputs_.push_back(path);
  RunReport::global().add_output(path);
}

void Frame::output_dir(const fs::path& path) {
  for (const auto& in : input_dirs_)
    if (same_file(in, path)) throw OutputError(path, "refusing to write into an input folder");
  std::error_code ec;
  fs::create_directories(path, ec);
  if (!fs::is_directory(path)) throw OutputError(path, "cannot create output folder");
}

int Frame::run(int argc, char** argv, const std::function<void()>& body) {
  log::set_prefix(info_.name);
  std::string command_line;
  for (int i = 0; i < argc; ++i) command_line += (i ? " " : "") + quote_arg(argv[i]);
  RunReport::global().set_tool(info_.name, command_line);
  Provenance provenance;
  provenance.tool = info_.name;
  provenance.version = build_info::version;
  provenance.command_line = command_line;
  Provenance::set_current(provenance);

  try {
    app_.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app_.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app_.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app_.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << info_.name << ": error: " << e.what() << " (see --help)\n";
    return int(ExitCode::usage);
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  ExitCode code = ExitCode::ok;
  std::string message;
  try {
    log::set_level(log::parse_level(log_level_));
    set_thread_count(threads_);
    use_huge_pages_for_large_mats();
    if (!max_memory_text_.empty()) {
      max_memory_ = parse_memory_size(max_memory_text_);
      budget_bytes = max_memory_;
      limit_address_space(max_memory_, threads_);
    }
    const std::string line = str(info_.name, ": error: ", out_of_memory_message(), "\n");
    std::snprintf(out_of_memory_line, sizeof out_of_memory_line, "%s", line.c_str());
    previous_terminate = std::set_terminate(on_terminate);
    Progress::set_enabled(progress_mode_ != "off");
    Progress::set_force_terminal(progress_mode_ == "lines" ? 0 : -1);
    if (!report_path_.empty()) output(report_path_);
    gpu::set_requested_device(gpu::parse_device_kind(device_));
    body();
    if (gpu::device_resolved()) RunReport::global().set_metric("device", gpu::describe_active_device());
  } catch (const Error& e) {
    code = e.code();
    message = e.what();
  } catch (const std::bad_alloc&) {
    code = ExitCode::out_of_memory;
    message = out_of_memory_message();
  } catch (const std::exception& e) {
    // OpenCV reports a failed allocation as cv::Exception (-4: Insufficient memory), not bad_alloc.
    const bool opencv_out_of_memory = std::string(e.what()).find("Insufficient memory") != std::string::npos;
    code = opencv_out_of_memory ? ExitCode::out_of_memory : ExitCode::internal;
    message = opencv_out_of_memory ? std::string("out of memory: ") + e.what()
                                   : std::string("internal error: ") + e.what();
  }
  if (code != ExitCode::ok) log::error(message);

  RunReport::global().set_exit(int(code), message);
  // A --report naming an input was refused when the input was declared; it is not written either.
  const bool report_is_input = std::any_of(inputs_.begin(), inputs_.end(),
                                           [&](const fs::path& in) { return same_file(in, report_path_); });
  if (!report_path_.empty() && !report_is_input) {
    try {
      RunReport::global().write(report_path_);
    } catch (const std::exception& e) {
      log::error("cannot write the report: ", e.what());
      if (code == ExitCode::ok) code = ExitCode::output;
    }
  }
  return int(code);
}

}  // namespace pg::cli
