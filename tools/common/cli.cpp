#include "common/cli.h"

#include <unistd.h>
#include <csignal>
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

namespace fs = std::filesystem;

namespace pg::cli {
namespace {

void on_signal(int) {
  remove_temporaries_in_flight();
  static const char message[] = "pg: interrupted\n";
  [[maybe_unused]] auto n = ::write(STDERR_FILENO, message, sizeof message - 1);
  ::_exit(int(ExitCode::interrupted));
}

std::string quote_arg(const std::string& a) {
  if (!a.empty() && a.find_first_of(" \t\"'$\\") == std::string::npos) return a;
  std::string q = "'";
  for (char c : a) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
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

Frame::Frame(ToolInfo info) : info_(std::move(info)), app_(info_.summary, info_.name) {
  app_.set_version_flag("--version", std::string(info_.name) + " " + build_info::version);
  app_.add_option("--log-level", log_level_, "error, warn, info, debug or trace")->capture_default_str();
  app_.add_option("--threads", threads_, "worker threads (0 = all cores); results do not depend on it")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app_.add_option("--seed", seed_, "seed for every random choice; same inputs and seed, same outputs")
      ->capture_default_str();
  app_.add_option("--report", report_path_, "write the run report (JSON: metrics, timings, memory) here");
  app_.add_option("--progress", progress_mode_,
                  "progress lines on stderr: auto (redraw on a terminal, lines otherwise), lines, off")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "lines", "off"}));
  app_.footer("Example:\n" + info_.example + "\n\n" + exit_code_help());
  app_.fallthrough();  // the common flags also work after a subcommand: `pg-x run --threads 2`
}

void Frame::input(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "no such file");
  if (fs::is_directory(path, ec)) throw InputError(path, "is a folder, expected a file");
  inputs_.push_back(path);
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

void Frame::output(const fs::path& path) {
  for (const auto& in : inputs_)
    if (same_file(in, path)) throw OutputError(path, "refusing to overwrite an input of this run");
  fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw OutputError(path, "output folder does not exist");
  if (fs::is_directory(path, ec)) throw OutputError(path, "is a folder, expected a file name");
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
    Progress::set_enabled(progress_mode_ != "off");
    Progress::set_force_terminal(progress_mode_ == "lines" ? 0 : -1);
    if (!report_path_.empty()) output(report_path_);
    body();
  } catch (const Error& e) {
    code = e.code();
    message = e.what();
  } catch (const std::bad_alloc&) {
    code = ExitCode::out_of_memory;
    message = "out of memory";
  } catch (const std::exception& e) {
    code = ExitCode::internal;
    message = std::string("internal error: ") + e.what();
  }
  if (code != ExitCode::ok) log::error(message);

  RunReport::global().set_exit(int(code), message);
  if (!report_path_.empty()) {
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
