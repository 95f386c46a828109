#pragma once
// Reads any file pg writes with the reader its format names, so a TD (or a test) can check a file
// before a farm job consumes it. Throws InputError on the first problem.
#include <filesystem>
#include <string>

namespace pg::info {

// Returns a one-line description ("pg-cameras v1: 16 cameras") of a valid file.
std::string validate_file(const std::filesystem::path& path);

}  // namespace pg::info
