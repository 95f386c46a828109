#include <gtest/gtest.h>

#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <numeric>
#include <vector>

#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/hash.h"
#include "pg/core/json_file.h"
#include "pg/core/parallel.h"
#include "pg/core/provenance.h"
#include "pg/core/run_report.h"
#include "pg/core/system_memory.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::TempDir;

TEST(Hash, Sha256KnownVectors) {
  EXPECT_EQ(pg::sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(pg::sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(pg::sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  std::string million(1000000, 'a');
  EXPECT_EQ(pg::sha256_hex(million), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Hash, Fnv1a64KnownVector) {
  EXPECT_EQ(pg::fnv1a64("a", 1), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(pg::hex64(0xaf63dc4c8601ec8cull), "af63dc4c8601ec8c");
}

TEST(AtomicFile, WritesCompleteFileAndLeavesNoTemporary) {
  TempDir dir;
  fs::path target = dir / "out.txt";
  pg::write_file_atomically(target, "hello");
  EXPECT_EQ(pg::testing::read_text(target), "hello");
  int entries = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 1);
}

TEST(AtomicFile, FailedWriteKeepsOldFileAndRemovesTemporary) {
  TempDir dir;
  fs::path target = dir / "out.txt";
  pg::write_file_atomically(target, "old");
  EXPECT_THROW(pg::write_atomically(target,
                                    [](const fs::path& tmp) {
                                      std::ofstream(tmp) << "partial";
                                      throw std::runtime_error("killed half way");
                                    }),
               std::runtime_error);
  EXPECT_EQ(pg::testing::read_text(target), "old");
  int entries = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 1);
}

TEST(AtomicFile, TemporaryKeepsExtension) {
  EXPECT_EQ(pg::temporary_sibling("/a/b/depth.exr").extension(), ".exr");
  EXPECT_EQ(pg::temporary_sibling("/a/b/depth.exr").parent_path(), fs::path("/a/b"));
}

TEST(AtomicFile, MissingFolderIsAnOutputError) {
  TempDir dir;
  try {
    pg::write_file_atomically(dir / "nope" / "x.txt", "x");
    FAIL();
  } catch (const pg::Error& e) {
    EXPECT_EQ(e.code(), pg::ExitCode::output);
    EXPECT_NE(std::string(e.what()).find("x.txt"), std::string::npos);
  }
}

TEST(JsonFile, RejectsWrongFormatAndVersionNamingTheFile) {
  TempDir dir;
  fs::path p = dir / "c.json";
  pg::testing::write_text(p, R"({"format":"pg-other","version":1})");
  auto doc = pg::read_json_file(p);
  try {
    pg::check_format_header(doc, p, "pg-cameras", 1);
    FAIL();
  } catch (const pg::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("pg-other"), std::string::npos);
  }
  pg::testing::write_text(p, R"({"format":"pg-cameras","version":7})");
  doc = pg::read_json_file(p);
  EXPECT_THROW(pg::check_format_header(doc, p, "pg-cameras", 1), pg::InputError);
  pg::testing::write_text(p, R"({"format":"pg-cameras", "version":)");
  EXPECT_THROW(pg::read_json_file(p), pg::InputError);
  EXPECT_THROW(pg::read_json_file(dir / "missing.json"), pg::InputError);
}

TEST(JsonFile, ReaderNamesTheField) {
  nlohmann::json j = {{"a", {{"b", "text"}}}};
  pg::JsonReader r(j, "f.json", "");
  try {
    r.child("a").number("b");
    FAIL();
  } catch (const pg::InputError& e) {
    EXPECT_EQ(std::string(e.what()), "f.json: a: \"b\" is not a number");
  }
}

TEST(Parallel, ChunksAreIndependentOfThreadCount) {
  auto chunk_sums = [](int threads) {
    pg::set_thread_count(threads);
    std::vector<double> partial(100);
    pg::parallel_chunks(1000, 10, [&](std::int64_t b, std::int64_t e) {
      double s = 0;
      for (auto i = b; i < e; ++i) s += 1.0 / double(i + 1);
      partial[b / 10] = s;
    });
    pg::set_thread_count(0);
    return std::accumulate(partial.begin(), partial.end(), 0.0);
  };
  EXPECT_EQ(chunk_sums(1), chunk_sums(2));
}

TEST(RunReport, HasProvenanceHashesAndMemory) {
  TempDir dir;
  fs::path in = dir / "in.txt";
  pg::testing::write_text(in, "abc");
  auto& r = pg::RunReport::global();
  r.reset();
  r.add_input(in);
  r.add_input(in);  // read twice, listed once
  r.set_metric("rms", 0.25);
  r.add_timing("solve", 1.5);
  auto j = r.to_json();
  EXPECT_EQ(j["format"], "pg-run-report");
  EXPECT_EQ(j["inputs"][0]["sha256"], "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(j["inputs"][0]["bytes"], 3);
  EXPECT_EQ(j["inputs"].size(), 1u);
  EXPECT_EQ(j["metrics"]["rms"], 0.25);
  EXPECT_GT(j["peak_memory_bytes"].get<std::uint64_t>(), 0u);
  r.reset();
}

namespace {

// Linux reports what it can hand out; it is never more than the machine has.
TEST(SystemMemory, AvailableIsKnownAndWithinThePhysicalMemory) {
  const std::uint64_t physical =
      std::uint64_t(::sysconf(_SC_PHYS_PAGES)) * std::uint64_t(::sysconf(_SC_PAGESIZE));
  const std::uint64_t available = pg::available_memory_bytes();
  EXPECT_GT(available, std::uint64_t{16} << 20);
  EXPECT_LE(available, physical);
}

// A container's limit: what is left after the usage, with the reclaimable file cache not counted;
// "max" (cgroup v2) and v1's near-2^63 mean no limit.
TEST(SystemMemory, ACgroupLimitLeavesTheLimitLessWhatIsInUse) {
  const std::uint64_t mib = std::uint64_t{1} << 20;
  EXPECT_EQ(pg::memory_left_under_limit("1073741824", 600 * mib, 100 * mib), 524 * mib);
  EXPECT_EQ(pg::memory_left_under_limit("1073741824\n", 2048 * mib, 0), 0u);
  EXPECT_EQ(pg::memory_left_under_limit("max", 600 * mib, 0), std::nullopt);
  EXPECT_EQ(pg::memory_left_under_limit("9223372036854771712", 600 * mib, 0), std::nullopt);
  EXPECT_EQ(pg::memory_left_under_limit("", 600 * mib, 0), std::nullopt);
}

}  // namespace
