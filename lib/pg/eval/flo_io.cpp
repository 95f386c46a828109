#include "pg/eval/flo_io.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/log.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

constexpr float flo_magic = 202021.25f;
constexpr std::uintmax_t flo_header_bytes = 12;

}  // namespace

cv::Mat2f read_flo(const fs::path& path) {
  std::error_code ec;
  std::uintmax_t file_bytes = fs::file_size(path, ec);
  if (ec) throw InputError(path, "cannot read the file (" + ec.message() + ")");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open the file");

  char header[flo_header_bytes];
  if (file_bytes < flo_header_bytes || !in.read(header, flo_header_bytes))
    throw InputError(path, "too short for a .flo header (12 bytes)");
  float magic;
  std::int32_t width, height;
  std::memcpy(&magic, header, 4);
  std::memcpy(&width, header + 4, 4);
  std::memcpy(&height, header + 8, 4);
  if (magic != flo_magic) throw InputError(path, "not a Middlebury .flo file (bad magic, expected 'PIEH')");
  if (width < 1 || height < 1 || width > max_flo_dimension || height > max_flo_dimension)
    throw InputError(path, str("flow size ", width, "x", height, " is outside 1..", max_flo_dimension));
  std::uintmax_t expected = flo_header_bytes + std::uintmax_t(width) * std::uintmax_t(height) * 8;
  if (file_bytes != expected)
    throw InputError(path, str("file has ", file_bytes, " bytes but a ", width, "x", height, " flow needs ",
                               expected, file_bytes < expected ? " (truncated)" : " (trailing data)"));

  cv::Mat2f flow(height, width);
  for (int row = 0; row < height; ++row)
    if (!in.read(reinterpret_cast<char*>(flow.ptr<cv::Vec2f>(row)), std::streamsize(width) * 8))
      throw InputError(path, "read failed (truncated?)");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (auto& f : flow)
    if (!flow_is_known(f)) f = cv::Vec2f(nan, nan);
  return flow;
}

void write_flo(const fs::path& path, const cv::Mat2f& flow) {
  if (flow.empty()) throw Error(ExitCode::internal, "write_flo: empty flow");
  std::string bytes(flo_header_bytes + std::size_t(flow.total()) * 8, '\0');
  std::int32_t width = flow.cols, height = flow.rows;
  std::memcpy(bytes.data(), &flo_magic, 4);
  std::memcpy(bytes.data() + 4, &width, 4);
  std::memcpy(bytes.data() + 8, &height, 4);
  char* out = bytes.data() + flo_header_bytes;
  for (int row = 0; row < flow.rows; ++row) {
    for (int col = 0; col < flow.cols; ++col, out += 8) {
      cv::Vec2f f = flow(row, col);
      if (!flow_is_known(f)) f = cv::Vec2f(flo_unknown_value, flo_unknown_value);
      std::memcpy(out, &f[0], 8);
    }
  }
  write_file_atomically(path, bytes);
}

}  // namespace pg
