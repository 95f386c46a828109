// Every stage tool gives the same outputs (pg-info digest: content without provenance) with
// --threads 1 and --threads 2, and twice with the same seed.
#include <gtest/gtest.h>

#include "pg/testing/testing.h"
#include "stage_runs.h"

namespace {

using pg::reliability::StageRun;

class Determinism : public ::testing::TestWithParam<StageRun> {};

TEST_P(Determinism, SameDigestsAcrossThreadCountsAndRepeatedRuns) {
  const StageRun& stage = GetParam();
  pg::testing::TempDir dir;
  std::string err;
  ASSERT_EQ(pg::reliability::run_stage_as(stage, dir.path(), "t1", {"--threads", "1", "--seed", "7"}, &err),
            0)
      << err;
  ASSERT_EQ(pg::reliability::run_stage_as(stage, dir.path(), "t2", {"--threads", "2", "--seed", "7"}, &err),
            0)
      << err;
  ASSERT_EQ(pg::reliability::run_stage_as(stage, dir.path(), "t2b", {"--threads", "2", "--seed", "7"}, &err),
            0)
      << err;
  const auto one = pg::reliability::output_digests(dir / "t1");
  const auto two = pg::reliability::output_digests(dir / "t2");
  const auto again = pg::reliability::output_digests(dir / "t2b");
  ASSERT_FALSE(one.empty());
  for (const auto& [file, digest] : two) {
    EXPECT_EQ(one.count(file), 1u) << stage.tool << ": " << file << " only written with --threads 2";
    EXPECT_EQ(digest, again.at(file)) << stage.tool << ": " << file << " differs between two identical runs";
    if (one.count(file)) {
      EXPECT_EQ(digest, one.at(file)) << stage.tool << ": " << file << " depends on --threads";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Stages, Determinism, ::testing::ValuesIn(pg::reliability::stage_runs()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
