// Ground-truth camera importers: the published Middlebury and Strecha files read as their documentation
// says, and malformed files refused.
#include "pg/eval/truth_import.h"

#include <gtest/gtest.h>

#include "pg/core/error.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

TEST(TruthImport, MiddleburyParProjectsLikeTheFile) {
  PG_REQUIRE_REAL_DATA(folder, "multiview/templeSparseRing");
  const CameraSet set = import_middlebury_par(folder / "templeSR_par.txt");
  ASSERT_EQ(set.cameras.size(), 16u);
  const Camera& c = set.cameras[0];
  EXPECT_EQ(c.id, "templeSR0001");
  EXPECT_EQ(c.width, 640);
  EXPECT_DOUBLE_EQ(c.intrinsics.fx, 1520.4);
  EXPECT_DOUBLE_EQ(c.intrinsics.cy, 246.87);
  EXPECT_NEAR(c.cam_from_world.translation.z(), 0.614604845959, 1e-12);
  // The temple (README bounding box about (-0.05, 0, -0.06)..(0.1, 0.16, 0.06)) is in front of every camera.
  for (const Camera& cam : set.cameras)
    EXPECT_GT((cam.cam_from_world * Eigen::Vector3d(0.02, 0.08, 0)).z(), 0.3);
}

// templeRing's images here are 480x640, turned from the 640x480 frames of its parameters, the first
// 31 counter-clockwise and the rest clockwise. Its cameras then agree with templeSparseRing's for the
// same shots (same rotation in the two files, e.g. templeR0004 = templeSR0002, templeR0041 =
// templeSR0014): each is the sparse ring's camera turned the same way.
TEST(TruthImport, MiddleburyParOfTurnedImages) {
  PG_REQUIRE_REAL_DATA(folder, "multiview/templeRing");
  PG_REQUIRE_REAL_DATA(sparse_folder, "multiview/templeSparseRing");
  EXPECT_EQ(temple_ring_quarter_turns("templeR0031.png"), 1);
  EXPECT_EQ(temple_ring_quarter_turns("templeR0032.png"), -1);
  EXPECT_EQ(temple_ring_quarter_turns("templeSR0001.png"), 0);
  const CameraSet ring = import_middlebury_par(folder / "templeR_par.txt", temple_ring_quarter_turns);
  const CameraSet sparse = import_middlebury_par(sparse_folder / "templeSR_par.txt");
  ASSERT_EQ(ring.cameras.size(), 47u);
  const Camera& c = ring.cameras[0];
  EXPECT_EQ(c.width, 480);
  EXPECT_EQ(c.height, 640);
  EXPECT_DOUBLE_EQ(c.intrinsics.fx, 1525.9);
  EXPECT_DOUBLE_EQ(c.intrinsics.cx, 246.87);
  EXPECT_DOUBLE_EQ(c.intrinsics.cy, 639 - 302.32);
  for (const auto& [r, s, turns] : {std::tuple{3, 1, 1}, std::tuple{40, 13, -1}}) {
    const Camera expected = turned_camera(sparse.cameras[s], turns);
    EXPECT_NEAR(ring.cameras[r].cam_from_world.rotation.angularDistance(expected.cam_from_world.rotation), 0,
                1e-9);
    EXPECT_DOUBLE_EQ(ring.cameras[r].intrinsics.cy, expected.intrinsics.cy);
  }
}

TEST(TruthImport, StrechaCamerasKeepTheCentre) {
  PG_REQUIRE_REAL_DATA(folder, "multiview/strecha/Herz-Jesus-P8/gt_dense_cameras");
  const CameraSet set = import_strecha_cameras(folder, "images");
  ASSERT_EQ(set.cameras.size(), 8u);
  const Camera& c = set.cameras[0];
  EXPECT_EQ(c.id, "0000");
  EXPECT_EQ(c.image, "images/0000.jpg");
  EXPECT_EQ(c.width, 3072);
  EXPECT_DOUBLE_EQ(c.intrinsics.fx, 2759.48);
  EXPECT_NEAR((c.cam_from_world.centre() - Eigen::Vector3d(-6.71999, -14.2551, 0.279539)).norm(), 0, 1e-5);
  const CameraSet half = import_strecha_cameras(folder, "images", 0.5);
  EXPECT_EQ(half.cameras[0].width, 1536);
  EXPECT_DOUBLE_EQ(half.cameras[0].intrinsics.fx, 2759.48 / 2);
  EXPECT_DOUBLE_EQ(half.cameras[0].intrinsics.cx, (1520.69 + 0.5) / 2 - 0.5);
}

TEST(TruthImport, RejectsMalformedFiles) {
  testing::TempDir dir;
  testing::write_text(dir / "bad_par.txt", "2\nimg.png 1 0 0 0 1 0 0 0 1\n");
  EXPECT_THROW(import_middlebury_par(dir / "bad_par.txt"), InputError);
  testing::write_text(dir / "zero_par.txt", "1\nimg.png 1 0 0 0 1 0 0 0 1 2 0 0 0 1 0 0 0 1 0 0 0\n");
  EXPECT_THROW(import_middlebury_par(dir / "zero_par.txt"), InputError);  // R is not a rotation
  EXPECT_THROW(import_strecha_cameras(dir.path()), InputError);           // no .camera files
}

}  // namespace
}  // namespace pg
