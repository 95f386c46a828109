// --max-memory: a stage that can blow up (merge at small voxel sizes, refine on huge meshes, depth on
// huge images) given too small a budget fails with exit code 5 (out of memory, retried by a farm on a
// bigger node) and leaves no output under its final name; never a crash. Every stage's outputs are
// the same under an ample budget.
#include <gtest/gtest.h>

#include <algorithm>

#include "pg/testing/testing.h"
#include "stage_runs.h"

namespace {

using pg::reliability::StageRun;

class MaxMemory : public ::testing::TestWithParam<StageRun> {};
class MaxMemoryOfLargeStages : public ::testing::TestWithParam<StageRun> {};

std::vector<StageRun> stages_that_can_blow_up() {
  std::vector<StageRun> runs;
  for (const StageRun& run : pg::reliability::stage_runs())
    if (run.name == "depth" || run.name == "merge" || run.name == "refine" || run.name == "sphdepth" ||
        run.name == "track")
      runs.push_back(run);
  return runs;
}

TEST_P(MaxMemoryOfLargeStages, TinyBudgetFailsEarlyWithExitCodeFiveAndNoOutputs) {
  const StageRun& stage = GetParam();
  // Each estimates its working set before allocating it (merge: the grids; depth: a pair's flow from
  // its cameras; refine: the mesh's and the views' buffers; track: the frames and one SIFT detection,
  // from the image headers), so the address-space backstop of the CLI frame (budget + per-thread
  // reserve) is never what stops them.
  pg::testing::TempDir dir;
  std::string err;
  const int code =
      pg::reliability::run_stage(stage, dir / "out", {"--threads", "1", "--max-memory", "1K"}, &err);
  EXPECT_EQ(code, 5) << stage.tool << " with --max-memory 1K: " << err;
  EXPECT_NE(err.find("--max-memory"), std::string::npos) << err;
  if (code == 5) {
    for (const auto& file : pg::reliability::final_outputs(dir / "out"))
      ADD_FAILURE() << stage.tool << " failed for memory but left " << file;
  }
}

TEST_P(MaxMemory, AmpleBudgetChangesNothing) {
  const StageRun& stage = GetParam();
  pg::testing::TempDir dir;
  std::string err;
  ASSERT_EQ(pg::reliability::run_stage_as(stage, dir.path(), "free", {"--threads", "1"}, &err), 0) << err;
  ASSERT_EQ(pg::reliability::run_stage_as(stage, dir.path(), "budget",
                                          {"--threads", "1", "--max-memory", "16G"}, &err),
            0)
      << err;
  EXPECT_EQ(pg::reliability::output_digests(dir / "free"), pg::reliability::output_digests(dir / "budget"));
}

INSTANTIATE_TEST_SUITE_P(Stages, MaxMemoryOfLargeStages, ::testing::ValuesIn(stages_that_can_blow_up()),
                         [](const auto& info) { return info.param.name; });
INSTANTIATE_TEST_SUITE_P(Stages, MaxMemory, ::testing::ValuesIn(pg::reliability::stage_runs()),
                         [](const auto& info) { return info.param.name; });

TEST(MaxMemory, MergeAtATinyVoxelSizeStopsBeforeAllocatingTheGrids) {
  pg::testing::TempDir dir;
  const auto depth = pg::reliability::scene("set") / "depth";
  const auto r = pg::testing::run_tool(
      "pg-merge", {"volume", "--depth", (depth / "view_000.exr").string(), "--voxel-size", "0.0005",
                   "--max-memory", "64M", "--out", (dir / "merged.ply").string(), "--progress", "off"});
  EXPECT_EQ(r.exit_code, 5) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("--max-memory"), std::string::npos) << r.stderr_text;
  EXPECT_FALSE(std::filesystem::exists(dir / "merged.ply"));
}

// Before, a budget given before the subcommand set only the address-space limit, and the first
// allocation past it ended in std::terminate (exit 134): OpenVDB's Tree::clear allocates while the
// std::bad_alloc unwinds. Either place, whatever runs out first, the answer is exit code 5.
TEST(MaxMemory, MergeOutOfMemoryIsExitCodeFiveWhereverTheBudgetIsGiven) {
  pg::testing::TempDir dir;
  const auto depth = (pg::reliability::scene("set") / "depth" / "view_000.exr").string();
  const std::vector<std::string> volume = {
      "volume",     "--depth", depth, "--voxel-size", "0.0003", "--out", (dir / "merged.ply").string(),
      "--progress", "off"};
  for (const char* threads : {"1", "2"})
    for (const char* budget : {"16M", "200M"}) {
      std::vector<std::string> before = {"--threads", threads, "--max-memory", budget};
      before.insert(before.end(), volume.begin(), volume.end());
      std::vector<std::string> after = volume;
      after.insert(after.end(), {"--threads", threads, "--max-memory", budget});
      for (const auto& args : {before, after}) {
        const auto r = pg::testing::run_tool("pg-merge", args);
        EXPECT_EQ(r.exit_code, 5) << "--threads " << threads << " --max-memory " << budget << ": "
                                  << r.stderr_text;
        const std::string mib = std::string(budget).substr(0, std::string(budget).size() - 1) + " MiB";
        EXPECT_NE(r.stderr_text.find("--max-memory " + mib), std::string::npos) << r.stderr_text;
        EXPECT_FALSE(std::filesystem::exists(dir / "merged.ply"));
      }
    }
}

TEST(MaxMemory, MalformedBudgetIsAUsageError) {
  pg::testing::TempDir dir;
  const auto r =
      pg::testing::run_tool("pg-synth", {"set", "--out", (dir / "s").string(), "--max-memory", "lots"});
  EXPECT_EQ(r.exit_code, 2) << r.stderr_text;
  EXPECT_NE(r.stderr_text.find("--max-memory"), std::string::npos) << r.stderr_text;
}

}  // namespace
