#include "pg/testing/testing.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "pg/build_info.h"

extern char** environ;
namespace fs = std::filesystem;

namespace pg::testing {

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  std::random_device rd;
  path_ = fs::temp_directory_path() / ("pg-test-" + std::to_string(::getpid()) + "-" +
                                       std::to_string(counter++) + "-" + std::to_string(rd()));
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::optional<fs::path> real_data(const std::string& relative) {
  const char* env = std::getenv("PG_DATA_DIR");
  fs::path root = env && *env ? fs::path(env) : fs::path(build_info::default_data_dir);
  fs::path p = root / relative;
  if (fs::exists(p)) return p;
  return std::nullopt;
}

fs::path bin_dir() {
  const char* env = std::getenv("PG_BIN_DIR");
  if (env && *env) return env;
  return fs::path(build_info::source_dir) / "build" / "bin";
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

void write_bytes(const fs::path& path, const std::vector<unsigned char>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

ToolResult run_tool(const std::string& tool, const std::vector<std::string>& args,
                    const std::vector<std::string>& extra_env) {
  TempDir capture;
  fs::path out_path = capture / "stdout", err_path = capture / "stderr";
  std::string exe = (bin_dir() / tool).string();
  std::vector<std::string> argv_storage{exe};
  argv_storage.insert(argv_storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_storage;
  for (char** e = environ; *e; ++e) env_storage.emplace_back(*e);
  env_storage.insert(env_storage.end(), extra_env.begin(), extra_env.end());
  std::vector<char*> envp;
  for (auto& e : env_storage) envp.push_back(e.data());
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid;
  ToolResult result;
  if (posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), envp.data()) != 0) {
    posix_spawn_file_actions_destroy(&actions);
    result.stderr_text = "cannot start " + exe;
    return result;
  }
  posix_spawn_file_actions_destroy(&actions);
  int status = 0;
  waitpid(pid, &status, 0);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.stdout_text = read_text(out_path);
  result.stderr_text = read_text(err_path);
  return result;
}

bool shared_folder(const std::string& name, const fs::path& maker, fs::path& folder,
                   const std::function<bool(const fs::path& partial)>& make) {
  std::error_code ec;
  const auto stamp = fs::last_write_time(maker, ec).time_since_epoch().count();
  const std::string key = name + "-" + std::to_string(fs::file_size(maker, ec)) + "-" + std::to_string(stamp);
  const fs::path cache = bin_dir().parent_path() / "test-cache";
  fs::create_directories(cache);
  folder = cache / key;
  // flock is released when the descriptor closes, also when a test process dies.
  const int lock = ::open((cache / (name + ".lock")).c_str(), O_RDWR | O_CREAT, 0644);
  if (lock < 0 || ::flock(lock, LOCK_EX) != 0) {
    if (lock >= 0) ::close(lock);
    throw std::runtime_error("cannot lock " + (cache / (name + ".lock")).string());
  }
  bool made = true;
  if (!fs::exists(folder / ".complete")) {
    for (const fs::directory_entry& entry : fs::directory_iterator(cache))  // older builds' folders
      if (entry.is_directory() && entry.path().filename().string().starts_with(name + "-"))
        fs::remove_all(entry.path(), ec);
    const fs::path partial = cache / (key + ".partial");
    made = make(partial);
    if (made) {
      write_text(partial / ".complete", "");
      fs::rename(partial, folder);
    }
  }
  ::close(lock);
  return made;
}

SharedOutput shared_tool_output(const std::string& name, const std::string& tool,
                                const std::vector<std::string>& args) {
  SharedOutput out;
  out.run.exit_code = 0;
  try {
    shared_folder(name, bin_dir() / tool, out.folder, [&](const fs::path& partial) {
      std::vector<std::string> full_args = args;
      full_args.insert(full_args.end(), {"--out", partial.string()});
      out.run = run_tool(tool, full_args);
      return out.run.exit_code == 0;
    });
  } catch (const std::runtime_error& e) {
    out.run = {-1, "", e.what()};
  }
  return out;
}

}  // namespace pg::testing
