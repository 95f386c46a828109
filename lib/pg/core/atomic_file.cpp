#include "pg/core/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <mutex>
#include <set>

#include "pg/core/error.h"

namespace fs = std::filesystem;

namespace pg {
namespace {
std::atomic<unsigned> g_counter{0};
std::mutex g_in_flight_mutex;
std::set<std::string> g_in_flight;

struct InFlight {
  explicit InFlight(const fs::path& p) : path(p.string()) {
    std::lock_guard lock(g_in_flight_mutex);
    g_in_flight.insert(path);
  }
  ~InFlight() {
    std::lock_guard lock(g_in_flight_mutex);
    g_in_flight.erase(path);
  }
  std::string path;
};

void fsync_path(const fs::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}
}  // namespace

fs::path temporary_sibling(const fs::path& target) {
  std::string name = ".";
  name.append(target.stem().string());
  name.append(".pg-tmp-");
  name.append(std::to_string(::getpid()));
  name.append("-");
  name.append(std::to_string(g_counter++));
  name.append(target.extension().string());
  return target.parent_path() / name;
}

void write_atomically(const fs::path& target, const std::function<void(const fs::path& tmp)>& write) {
  fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(folder)) throw OutputError(target, "folder does not exist");
  fs::path tmp = temporary_sibling(target);
  InFlight guard(tmp);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
  if (!fs::exists(tmp)) throw OutputError(target, "writer produced no file");
  fsync_path(tmp);
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw OutputError(target, "cannot rename temporary file into place: " + ec.message());
  }
}

void write_file_atomically(const fs::path& target, std::string_view bytes) {
  write_atomically(target, [&](const fs::path& tmp) {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw OutputError(target, "cannot open for writing");
    bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    ok = (std::fclose(f) == 0) && ok;
    if (!ok) throw OutputError(target, "write failed (disk full?)");
  });
}

void remove_temporaries_in_flight() noexcept {
  // Called from a signal handler: unlink is async-signal-safe; the lock is a best effort.
  if (!g_in_flight_mutex.try_lock()) return;
  for (const auto& p : g_in_flight) ::unlink(p.c_str());
  g_in_flight_mutex.unlock();
}

}  // namespace pg
