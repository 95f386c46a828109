#pragma once
// A content digest of a pg file that ignores provenance (which names the command line and the time),
// so two runs can be compared for identical results: same digest, same data.
#include <filesystem>
#include <string>

namespace pg::info {

// SHA-256 over the decoded content: JSON without "provenance", EXR channels +
// camera + kind, mesh arrays and properties, .flo vectors, .vdb grids' active voxels and metadata without
// pg/provenance, image pixels. Throws InputError for unreadable files.
std::string content_digest(const std::filesystem::path& path);

}  // namespace pg::info
