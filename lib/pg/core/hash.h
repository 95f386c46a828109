#pragma once
// Hashes for provenance (SHA-256 of input files) and identity checks (FNV-1a 64 of face lists).
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

namespace pg {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t size);
  // Finishes and returns the lowercase hex digest; the object must not be updated afterwards.
  std::string hex_digest();

 private:
  void compress(const std::uint8_t* block);
  std::uint32_t state_[8];
  std::uint8_t buffer_[64];
  std::size_t buffered_ = 0;
  std::uint64_t total_bytes_ = 0;
};

std::string sha256_hex(std::string_view bytes);
// Streams the file; throws InputError if it cannot be read.
std::string sha256_file(const std::filesystem::path& path);

// FNV-1a 64-bit over raw bytes, chainable through `seed`.
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed = 0xcbf29ce484222325ull);
std::string hex64(std::uint64_t value);

}  // namespace pg
