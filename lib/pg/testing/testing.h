#pragma once
// Test helpers: a fresh temporary folder per test, the real-data folder, and running a tool binary.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace pg::testing {

// A folder removed at destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// The real third-party data folder: $PG_DATA_DIR, else ../shared/data beside the source tree.
// Returns nullopt when `relative` is absent beneath it (the caller GTEST_SKIPs with a message).
std::optional<std::filesystem::path> real_data(const std::string& relative);

// Folder holding the pg-* executables: $PG_BIN_DIR, set by CTest.
std::filesystem::path bin_dir();

struct ToolResult {
  int exit_code = -1;
  std::string stdout_text;
  std::string stderr_text;
};

// Runs bin_dir()/tool with args (no shell), capturing both streams.
ToolResult run_tool(const std::string& tool, const std::vector<std::string>& args,
                    const std::vector<std::string>& extra_env = {});

// A folder made once per build and shared by every test process that asks for it: the first caller
// runs `make(partial)` while the others wait on a lock, later callers reuse the folder. It lives under
// the build tree, keyed by `name` and by the size and time of `maker` (the tool or test executable
// that makes it), so a rebuild makes a fresh one. For inputs that are slow to make and only read by
// the tests. `make` returns whether it succeeded; only then is the folder renamed into place and
// kept. Sets `folder`; returns false when this call's `make` failed. Throws std::runtime_error when
// the lock cannot be taken.
bool shared_folder(const std::string& name, const std::filesystem::path& maker, std::filesystem::path& folder,
                   const std::function<bool(const std::filesystem::path& partial)>& make);

// A tool's output folder shared that way (a rendered orbit): `tool args... --out FOLDER`. `run` is the
// tool's result when this call made the folder, exit code 0 otherwise.
struct SharedOutput {
  std::filesystem::path folder;
  ToolResult run;
};
SharedOutput shared_tool_output(const std::string& name, const std::string& tool,
                                const std::vector<std::string>& args);

std::string read_text(const std::filesystem::path& path);
void write_text(const std::filesystem::path& path, const std::string& text);
void write_bytes(const std::filesystem::path& path, const std::vector<unsigned char>& bytes);

}  // namespace pg::testing

// Skips the test with a message when real data is absent.
#define PG_REQUIRE_REAL_DATA(var, relative)                                                     \
  auto var##_opt = ::pg::testing::real_data(relative);                                          \
  if (!var##_opt) GTEST_SKIP() << "real data '" << relative << "' not found (set PG_DATA_DIR)"; \
  const std::filesystem::path var = *var##_opt
