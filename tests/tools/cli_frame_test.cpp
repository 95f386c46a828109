// The shared CLI frame's conventions, checked on real tools (pg-synth writes many outputs; pg-eval
// reads inputs): help, version, exit codes, report, progress lines, atomic outputs, thread-independence.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "pg/core/hash.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;
using pg::testing::TempDir;

namespace {
int count_lines(const std::string& text) {
  return int(std::count(text.begin(), text.end(), '\n'));
}

// Content digests (pg-info digest: provenance, which names the command line and time, left out).
std::map<std::string, std::string> hash_tree(const fs::path& root) {
  std::map<std::string, std::string> hashes;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (!e.is_regular_file()) continue;
    auto r = run_tool("pg-info", {"digest", e.path().string(), "--log-level", "error"});
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    hashes[fs::relative(e.path(), root).string()] = r.stdout_text.substr(0, 64);
  }
  return hashes;
}
}  // namespace

TEST(CliFrame, HelpHasAnExampleAndExitCodes) {
  auto r = run_tool("pg-synth", {"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.stdout_text.find("Example:"), std::string::npos);
  EXPECT_NE(r.stdout_text.find("pg-synth set --out"), std::string::npos);
  EXPECT_NE(r.stdout_text.find("Exit codes"), std::string::npos);
  for (const char* flag : {"--log-level", "--threads", "--seed", "--report", "--progress", "--version"})
    EXPECT_NE(r.stdout_text.find(flag), std::string::npos) << flag;
}

TEST(CliFrame, VersionPrintsToolAndVersion) {
  auto r = run_tool("pg-synth", {"--version"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.stdout_text.rfind("pg-synth 0.", 0), 0u) << r.stdout_text;
}

TEST(CliFrame, BadUsageIsExitCode2WithOneLine) {
  auto r = run_tool("pg-synth", {"set", "--out", "x", "--no-such-flag"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(count_lines(r.stderr_text), 1) << r.stderr_text;
  r = run_tool("pg-synth", {"nonsense-scene", "--out", "x"});
  EXPECT_EQ(r.exit_code, 2);
  r = run_tool("pg-synth", {"set", "--out", "x", "--width", "3"});
  EXPECT_EQ(r.exit_code, 2);
  r = run_tool("pg-synth", {"set", "--out", "x", "--log-level", "loud"});
  EXPECT_EQ(r.exit_code, 2);
}

TEST(CliFrame, UnwritableOutputIsExitCode6) {
  TempDir dir;
  pg::testing::write_text(dir / "file", "x");
  auto r = run_tool("pg-synth", {"checkerboard", "--views", "1", "--out", (dir / "file" / "sub").string()});
  EXPECT_EQ(r.exit_code, 6) << r.stderr_text;
}

TEST(CliFrame, ReportProgressAndAtomicOutputs) {
  TempDir dir;
  fs::path out = dir / "board";
  fs::path report = dir / "report.json";
  auto r = run_tool("pg-synth", {"checkerboard", "--views", "3", "--out", out.string(), "--report",
                                 report.string(), "--progress", "lines", "--supersample", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  // Progress: whole lines with a percentage, never a carriage return when not a terminal.
  EXPECT_EQ(r.stderr_text.find('\r'), std::string::npos);
  EXPECT_NE(r.stderr_text.find("progress render 100% (3/3)"), std::string::npos) << r.stderr_text;
  // Report: the outputs with sizes and hashes, metrics, memory, exit code.
  auto j = nlohmann::json::parse(pg::testing::read_text(report));
  EXPECT_EQ(j["format"], "pg-run-report");
  EXPECT_EQ(j["tool"], "pg-synth");
  EXPECT_EQ(j["exit_code"], 0);
  EXPECT_GT(j["peak_memory_bytes"].get<double>(), 1e6);
  EXPECT_EQ(j["metrics"]["views"], 3);
  bool found_cameras = false;
  for (const auto& o : j["outputs"])
    if (o["path"].get<std::string>().ends_with("cameras.json")) {
      found_cameras = true;
      EXPECT_EQ(o["sha256"], pg::sha256_file(out / "cameras.json"));
    }
  EXPECT_TRUE(found_cameras);
  EXPECT_NE(j["command_line"].get<std::string>().find("--views 3"), std::string::npos);
  // No temporaries left behind.
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".pg-tmp"), std::string::npos) << e.path();
}

TEST(CliFrame, FailedRunStillWritesTheReport) {
  TempDir dir;
  fs::path report = dir / "report.json";
  pg::testing::write_text(dir / "file", "x");
  auto r = run_tool("pg-synth",
                    {"checkerboard", "--out", (dir / "file" / "sub").string(), "--report", report.string()});
  EXPECT_EQ(r.exit_code, 6);
  auto j = nlohmann::json::parse(pg::testing::read_text(report));
  EXPECT_EQ(j["exit_code"], 6);
  EXPECT_FALSE(j["exit_message"].get<std::string>().empty());
}

// Whatever order a tool declares its files in, the report and the outputs never replace an input,
// and no two outputs share a file (one would silently replace the other).
TEST(CliFrame, NoOutputReplacesAnInputOrAnotherOutput) {
  TempDir dir;
  auto r = run_tool("pg-synth", {"checkerboard", "--views", "3", "--out", (dir / "board").string()});
  ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
  const fs::path cameras = dir / "board" / "cameras.json";
  const std::string before = pg::sha256_file(cameras);
  const std::vector<std::string> eval = {"cameras", "--estimate", cameras.string(), "--truth",
                                         cameras.string()};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = eval;
    args.insert(args.end(), extra.begin(), extra.end());
    return run_tool("pg-eval", args);
  };
  r = with({"--report", cameras.string()});
  EXPECT_EQ(r.exit_code, 6) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("refusing to overwrite an input"), std::string::npos) << r.stderr_text;
  EXPECT_EQ(pg::sha256_file(cameras), before) << "the failed run's report is not written over the input";
  r = with({"--out", cameras.string()});
  EXPECT_EQ(r.exit_code, 6) << r.stderr_text;
  EXPECT_EQ(pg::sha256_file(cameras), before);
  r = with({"--out", (dir / "eval.json").string(), "--report", (dir / "eval.json").string()});
  EXPECT_EQ(r.exit_code, 6) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("named for two outputs"), std::string::npos) << r.stderr_text;
  r = with({"--out", (dir / "eval.json").string(), "--report", (dir / "report.json").string()});
  EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
}

TEST(CliFrame, OutputsDoNotDependOnThreadCount) {
  TempDir dir;
  auto a =
      run_tool("pg-synth", {"checkerboard", "--views", "2", "--threads", "1", "--out", (dir / "a").string()});
  auto b =
      run_tool("pg-synth", {"checkerboard", "--views", "2", "--threads", "2", "--out", (dir / "b").string()});
  ASSERT_EQ(a.exit_code, 0) << a.stderr_text;
  ASSERT_EQ(b.exit_code, 0) << b.stderr_text;
  auto ha = hash_tree(dir / "a"), hb = hash_tree(dir / "b");
  EXPECT_GE(ha.size(), 5u);
  EXPECT_EQ(ha, hb);
}

TEST(CliFrame, SameSeedSameOutputsOtherSeedOtherOutputs) {
  TempDir dir;
  auto run = [&](const std::string& name, const std::string& seed) {
    auto r = run_tool("pg-synth", {"set", "--views", "1", "--width", "160", "--height", "120", "--seed", seed,
                                   "--out", (dir / name).string()});
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    return hash_tree(dir / name);
  };
  auto a = run("a", "7"), b = run("b", "7"), c = run("c", "8");
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

// SIGKILL at random moments while writing: every file under its final name is complete (it decodes),
// and re-running completes the result.
TEST(CliFrame, KilledRunLeavesNoPartialOutput) {
  TempDir dir;
  fs::path out = dir / "set";
  std::string exe = (pg::testing::bin_dir() / "pg-synth").string();
  for (int delay_ms : {40, 90, 160, 260}) {
    std::vector<std::string> args = {exe, "set", "--views", "4", "--out", out.string(), "--progress", "off"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid;
    ASSERT_EQ(posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), environ), 0);
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    kill(pid, SIGKILL);
    int status;
    waitpid(pid, &status, 0);
    if (!fs::exists(out)) continue;  // killed before it created its folder
    for (const auto& e : fs::recursive_directory_iterator(out)) {
      if (!e.is_regular_file() || e.path().filename().string().starts_with(".")) continue;
      auto r = run_tool("pg-info", {"validate", e.path().string()});
      EXPECT_EQ(r.exit_code, 0) << e.path() << " is partial after SIGKILL at " << delay_ms
                                << " ms: " << r.stderr_text;
    }
  }
  auto r = run_tool("pg-synth", {"set", "--views", "4", "--out", out.string()});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_TRUE(fs::exists(out / "depth" / "view_003.exr"));
}
