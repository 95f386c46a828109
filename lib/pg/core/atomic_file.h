#pragma once
// Outputs are written under a temporary name in the destination folder and renamed into place, so a
// failed or killed run leaves either the old file, nothing, or the complete new file.
#include <filesystem>
#include <functional>

namespace pg {

// The temporary sibling used while `target` is written. It keeps the extension, so writers that pick a
// format from it (OpenCV, OpenEXR) still work: "dir/.name.pg-tmp-<pid>-<n>.ext".
std::filesystem::path temporary_sibling(const std::filesystem::path& target);

// Calls write(tmp) and renames tmp onto target. Removes tmp and rethrows if write throws; throws
// OutputError if the folder is missing or the rename fails.
void write_atomically(const std::filesystem::path& target,
                      const std::function<void(const std::filesystem::path& tmp)>& write);

// Writes bytes to target atomically (fsync before rename).
void write_file_atomically(const std::filesystem::path& target, std::string_view bytes);

// Registers temporaries in flight so a SIGINT/SIGTERM handler can remove them before exiting.
void remove_temporaries_in_flight() noexcept;

}  // namespace pg
