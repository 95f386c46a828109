#pragma once
// Typed errors. Library code throws these; the CLI frame maps each to a documented exit code
// (see formats/exit-codes.md). Messages are one line and name the file when a file is at fault.
#include <filesystem>
#include <stdexcept>
#include <string>

namespace pg {

enum class ExitCode : int {
  ok = 0,
  internal = 1,       // a bug: an unexpected exception
  usage = 2,          // bad command line or option values
  bad_input = 3,      // an input file is missing, unreadable or invalid
  failed = 4,         // the computation could not produce a result (e.g. too few views)
  out_of_memory = 5,  // allocation failed; a farm may retry on a bigger node
  output = 6,         // an output could not be written, or would overwrite an input
  interrupted = 130,  // SIGINT / SIGTERM
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// Bad option values or combinations.
class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ExitCode::usage, message) {}
};

// An input file that cannot be read or does not follow its format. The message starts with the path.
class InputError : public Error {
 public:
  InputError(const std::filesystem::path& file, const std::string& problem)
      : Error(ExitCode::bad_input, file.string() + ": " + problem), file_(file) {}
  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
};

// The algorithm ran but cannot produce a trustworthy result.
class FailedError : public Error {
 public:
  explicit FailedError(const std::string& message) : Error(ExitCode::failed, message) {}
};

// An output that cannot be written.
class OutputError : public Error {
 public:
  OutputError(const std::filesystem::path& file, const std::string& problem)
      : Error(ExitCode::output, file.string() + ": " + problem) {}
};

}  // namespace pg
