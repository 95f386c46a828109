// Kill-safety: each stage tool is SIGKILLed at points spread over its run time. Afterwards every
// output under its final name is complete (pg-info validate reads it), and re-running into the same
// folder completes with the same outputs as an undisturbed run.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <chrono>
#include <random>
#include <thread>

#include "pg/testing/testing.h"
#include "stage_runs.h"

extern char** environ;

namespace fs = std::filesystem;
using pg::reliability::StageRun;

namespace {

// Starts the stage, kills it after `delay` (if still running); returns whether it was killed.
bool run_and_kill(const StageRun& stage, const fs::path& out, std::chrono::milliseconds delay) {
  std::vector<std::string> args = stage.args(pg::reliability::shared_inputs(), out);
  args.insert(args.begin(), (pg::testing::bin_dir() / stage.tool).string());
  args.insert(args.end(), {"--progress", "off", "--log-level", "error", "--threads", "2"});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw std::runtime_error("cannot start " + args[0]);
  std::this_thread::sleep_for(delay);
  const bool killed = ::kill(pid, SIGKILL) == 0;
  int status = 0;
  ::waitpid(pid, &status, 0);
  return killed && WIFSIGNALED(status);
}

class KillSafety : public ::testing::TestWithParam<StageRun> {};

TEST_P(KillSafety, NoPartialOutputsAndRerunCompletes) {
  const StageRun& stage = GetParam();
  pg::testing::TempDir dir;
  std::string err;
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(pg::reliability::run_stage_as(stage, dir.path(), "reference", {"--threads", "2"}, &err), 0)
      << err;
  const auto duration =
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
  const auto reference = pg::reliability::output_digests(dir / "reference");

  std::mt19937 random(13);  // fixed: the same kill points on every run of the test
  constexpr int kills = 4;
  for (int k = 0; k < kills; ++k) {
    // Kill points spread over the run, jittered within their quarter; the first run into an empty
    // folder, later ones over the partial results of the previous kill.
    std::uniform_real_distribution<double> within(k / double(kills), (k + 1) / double(kills));
    const auto delay = std::chrono::milliseconds(std::int64_t(within(random) * duration.count()));
    const fs::path out = dir / "run";  // the reference's output paths
    run_and_kill(stage, out, delay);
    for (const fs::path& file : pg::reliability::final_outputs(out)) {
      if (!pg::reliability::validatable(file)) continue;
      const auto r = pg::testing::run_tool("pg-info", {"validate", file.string()});
      EXPECT_EQ(r.exit_code, 0) << stage.tool << " killed after " << delay.count() << " ms left a partial "
                                << file << ": " << r.stderr_text;
    }
  }
  ASSERT_EQ(pg::reliability::run_stage(stage, dir / "run", {"--threads", "2"}, &err), 0) << err;
  EXPECT_EQ(pg::reliability::output_digests(dir / "run"), reference)
      << stage.tool << ": re-running over killed runs gave different outputs";
}

INSTANTIATE_TEST_SUITE_P(Stages, KillSafety, ::testing::ValuesIn(pg::reliability::stage_runs()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
