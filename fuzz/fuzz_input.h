#pragma once
// Shared harness of the reader fuzz targets. The readers take paths, so each input is written to a
// per-process scratch file and read back. A reader may reject the input only with pg::InputError
// (exit code 3 in the tools); any other exception escaping is a finding, so it aborts the run.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include "pg/core/error.h"

namespace pg::fuzz {

// The scratch file for this process, with the extension the reader dispatches on.
inline std::filesystem::path scratch_path(const std::string& extension) {
  const std::filesystem::path shm = "/dev/shm";
  const std::filesystem::path dir =
      std::filesystem::is_directory(shm) ? shm : std::filesystem::temp_directory_path();
  return dir / ("pg-fuzz-" + std::to_string(::getpid()) + extension);
}

inline std::filesystem::path write_scratch(const std::uint8_t* data, std::size_t size,
                                           const std::string& extension) {
  const std::filesystem::path path = scratch_path(extension);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  return path;
}

// Runs read(path) on the input; InputError is the one accepted way to refuse it.
template <class Read>
void read_accepting_input_errors(const std::filesystem::path& path, Read&& read) {
  try {
    read(path);
  } catch (const pg::InputError&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reader threw something other than pg::InputError: %s\n", e.what());
    std::abort();
  }
}

}  // namespace pg::fuzz
