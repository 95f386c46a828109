#include <gtest/gtest.h>

#include <openvdb/openvdb.h>

#include "pg/core/error.h"
#include "pg/eval/mesh_eval.h"
#include "pg/fusion/depth_agreement.h"
#include "pg/fusion/fusion_test_scenes.h"
#include "pg/fusion/mesh_cleanup.h"
#include "pg/fusion/tsdf_volume.h"
#include "pg/testing/testing.h"

namespace pg::fusion {
namespace {

using testing::orbit;
using testing::render_depth;

Mesh set_scene() {
  Mesh scene = testing::ground(2.0f);
  testing::append(scene, testing::box({0.3f, -0.6f, 0.0f}, {0.9f, 0.0f, 0.5f}));
  testing::append(scene, testing::sphere({-0.5f, 0.4f, 0.45f}, 0.45f));
  return scene;
}

std::vector<DepthFrame> frames_of(const Mesh& scene, const std::vector<Camera>& cameras,
                                  const WeightOptions& weights = {}) {
  const TriangleBvh bvh(scene);
  std::vector<DepthFrame> frames;
  for (const Camera& camera : cameras)
    frames.push_back(make_depth_frame(render_depth(bvh, camera), camera.id, weights));
  return frames;
}

// The faces of the truth that some frame sees (their centre is within `tolerance` of its depth).
Mesh observed_part(const Mesh& truth, const std::vector<DepthFrame>& frames, double tolerance) {
  Mesh seen;
  seen.positions = truth.positions;
  for (const auto& f : truth.faces) {
    const Eigen::Vector3d centre =
        ((truth.positions[f[0]] + truth.positions[f[1]] + truth.positions[f[2]]) / 3.0f).cast<double>();
    for (const DepthFrame& frame : frames) {
      const Eigen::Vector3d p = frame.camera.cam_from_world * centre;
      Eigen::Vector2d pixel;
      if (!frame.camera.project(p, pixel) || !frame.camera.in_image(pixel)) continue;
      const float d = frame.depth(int(std::lround(pixel.y())), int(std::lround(pixel.x())));
      if (std::isfinite(d) && std::abs(d - p.z()) < tolerance) {
        seen.faces.push_back(f);
        break;
      }
    }
  }
  remove_unused_vertices(seen);
  return seen;
}

TEST(Tsdf, ExactDepthMapsGiveAccuracyBelowOneVoxelAndCompleteness) {
  const double voxel = 0.03;
  const Mesh truth = set_scene();
  const auto frames = frames_of(truth, orbit(12, 3.0, 1.8, {0, 0, 0.2}, 128, 96, 110));
  TsdfVolume volume({.voxel_size = voxel});
  for (const auto& frame : frames) volume.integrate(frame);
  const Mesh merged = volume.extract_mesh();
  ASSERT_GT(merged.face_count(), 1000u);
  const Mesh seen = observed_part(truth, frames, voxel / 2);
  const MeshEvalResult eval =
      evaluate_mesh(merged, seen, {.samples = 30000, .thresholds = {voxel, 2 * voxel}});
  std::cout << "synthetic set, voxel " << voxel << ": accuracy p90 " << eval.accuracy.p90
            << ", completeness within 2v " << eval.recall[1] << ", faces " << merged.face_count() << "\n";
  EXPECT_LT(eval.accuracy.p90, voxel);
  EXPECT_GT(eval.recall[1], 0.95);
  // Confidence is the accumulated weight: present, positive.
  ASSERT_EQ(merged.vertex_properties.at("confidence").size(), merged.vertex_count());
  for (float c : merged.vertex_properties.at("confidence")) ASSERT_GT(c, 0.0f);
}

TEST(Tsdf, SphereIsWoundOutwardsAndLiesOnTheTrueRadius) {
  const double voxel = 0.02, radius = 0.5;
  const Mesh truth = testing::sphere({0, 0, 0}, float(radius), 96, 192);
  std::vector<Camera> cameras = orbit(8, 2.0, 0.8, {0, 0, 0}, 96, 96, 100);
  for (const auto& c : orbit(4, 0.3, -2.0, {0, 0, 0}, 96, 96, 100)) cameras.push_back(c);
  TsdfVolume volume({.voxel_size = voxel, .truncation = 3 * voxel});
  for (const auto& frame : frames_of(truth, cameras)) volume.integrate(frame);
  const Mesh merged = volume.extract_mesh();
  ASSERT_GT(merged.face_count(), 1000u);
  std::size_t outward = 0;
  double worst = 0;
  for (const auto& f : merged.faces) {
    const Eigen::Vector3f a = merged.positions[f[0]], b = merged.positions[f[1]], c = merged.positions[f[2]];
    outward += (b - a).cross(c - a).dot(a + b + c) > 0;
  }
  for (const auto& p : merged.positions) worst = std::max(worst, std::abs(p.norm() - radius));
  EXPECT_GT(double(outward) / merged.face_count(), 0.99);
  EXPECT_LT(worst, voxel / 2);  // the TSDF of a smooth surface is exact to interpolation error
  // Distances are measured along the viewing rays: at least the true distance, more for oblique rays.
  ASSERT_TRUE(volume.distance_at({radius + 0.01, 0, 0}).has_value());
  EXPECT_GT(*volume.distance_at({radius + 0.01, 0, 0}), 0.01 - voxel / 8);
  EXPECT_LT(*volume.distance_at({radius + 0.01, 0, 0}), 0.02);
  EXPECT_FALSE(volume.distance_at({0, 0, 0}).has_value());  // the inside was never observed
}

// Views that see a thin plate nearly edge-on meet its faces at grazing angles. A band behind the
// surface as deep as the truncation measured across it (truncation / cos along the ray) reaches
// through the plate into the free space beyond and thickens it; min_band_cos caps it at twice the
// truncation along the ray (p90 0.019 here; 0.023 with a cap of 10x, 0.009 with no cap at all).
TEST(Tsdf, ThinPartsSeenAtGrazingAnglesKeepTheirThickness) {
  const double voxel = 0.02;
  const Mesh truth = testing::box({-0.5f, -0.02f, 0.0f}, {0.5f, 0.02f, 0.6f}, 16);  // a plate 2 voxels thick
  const auto frames = frames_of(truth, orbit(12, 2.5, 1.0, {0, 0, 0.3}, 160, 120, 150));
  TsdfVolume volume({.voxel_size = voxel});
  for (const auto& frame : frames) volume.integrate(frame);
  const Mesh merged = volume.extract_mesh();
  const MeshEvalResult eval = evaluate_mesh(merged, observed_part(truth, frames, voxel / 2),
                                            {.samples = 30000, .thresholds = {voxel}});
  std::cout << "thin plate, voxel " << voxel << ": accuracy p90 " << eval.accuracy.p90 << ", p99 "
            << eval.accuracy.p99 << ", completeness within v " << eval.recall[0] << "\n";
  EXPECT_LT(eval.accuracy.p90, voxel);
  EXPECT_GT(eval.recall[0], 0.9);
}

// One frame of a floor lying on a voxel layer: the surface covers the frame's footprint but for the
// last voxel at its edges, exactly on the floor, and nothing is extracted at the back of the band. At
// the footprint's edge the cells holding the floor also cross towards voxels the frame never saw:
// extraction keeps each quad by its own grid edge and places the vertex by the measured crossings
// (asking every crossing of a vertex's cell to be measured covered 86% of the footprint; without
// the placement, the edge's vertices sat 0.7 voxels below the floor; before vertices on a cell's face
// were given their own cell, the floor on a voxel layer covered 33%).
TEST(Tsdf, OneFrameOfAFloorCoversItsFootprintAndNothingBehind) {
  const double voxel = 0.05;
  const Mesh floor = testing::ground(4.0f, 8);
  const TriangleBvh bvh(floor);
  const Camera camera = testing::pinhole_camera(64, 48, 60, {0.3, 0.2, 2.0}, {0.3, 0.2, 0.0});
  TsdfVolume volume({.voxel_size = voxel});
  volume.integrate(make_depth_frame(render_depth(bvh, camera), "floor", {}));
  const Mesh merged = volume.extract_mesh();
  double area = 0, farthest = 0;
  for (const auto& f : merged.faces) {
    const Eigen::Vector3f a = merged.positions[f[0]], b = merged.positions[f[1]], c = merged.positions[f[2]];
    area += 0.5 * (b - a).cross(c - a).norm();
    for (const Eigen::Vector3f* p : {&a, &b, &c}) farthest = std::max(farthest, double(std::abs(p->z())));
  }
  // The footprint of pixel edges [-0.5, 63.5] x [-0.5, 47.5] at 2 m.
  const double footprint = (64 * 2.0 / 60) * (48 * 2.0 / 60);
  std::cout << "floor, one frame: mesh area " << area / footprint << " of the footprint, farthest vertex "
            << farthest / voxel << " voxels off the floor\n";
  EXPECT_GT(area / footprint, 0.88);  // measured 0.89
  EXPECT_LT(area / footprint, 1.0);
  EXPECT_LT(farthest, 0.01 * voxel);
}

TEST(Tsdf, PartialVolumesCombineToTheSingleRun) {
  const double voxel = 0.04;
  const auto frames = frames_of(set_scene(), orbit(6, 3.0, 1.8, {0, 0, 0.2}, 96, 72, 85));
  TsdfVolume single({.voxel_size = voxel}), first({.voxel_size = voxel}), second({.voxel_size = voxel});
  for (std::size_t i = 0; i < frames.size(); ++i) {
    single.integrate(frames[i]);
    (i % 2 ? second : first).integrate(frames[i]);
  }
  first.merge_partial(second);
  const auto difference = single.compare(first);
  EXPECT_LT(difference.distance, 1e-6 * single.truncation() * 100);
  EXPECT_LT(difference.weight_relative, 1e-5);
  EXPECT_EQ(single.active_voxel_count(), first.active_voxel_count());

  // Through .vdb files, as farm jobs would pass them.
  pg::testing::TempDir dir;
  first.write_vdb(dir / "combined.vdb", Provenance::current());
  Provenance provenance;
  const TsdfVolume read = TsdfVolume::read_vdb(dir / "combined.vdb", &provenance);
  EXPECT_EQ(read.compare(first).distance, 0.0);
  EXPECT_EQ(read.compare(first).weight_relative, 0.0);
  EXPECT_DOUBLE_EQ(read.voxel_size(), voxel);
  EXPECT_DOUBLE_EQ(read.truncation(), first.truncation());
  EXPECT_EQ(provenance.tool, Provenance::current().tool);

  // A file whose surface grid lacks voxels its weight grid has (write_vdb never writes one) is
  // refused with the file's name rather than merged through a missing leaf.
  {
    openvdb::initialize();
    openvdb::io::File file((dir / "combined.vdb").string());
    file.open(false);
    openvdb::GridPtrVec grids;
    for (auto name = file.beginName(); name != file.endName(); ++name) {
      openvdb::GridBase::Ptr grid = file.readGrid(*name);
      if (*name == "surface") {
        openvdb::FloatGrid::Ptr empty = openvdb::FloatGrid::create();
        empty->setName("surface");
        empty->setTransform(grid->transform().copy());
        grid = empty;
      }
      grids.push_back(grid);
    }
    const openvdb::MetaMap::Ptr meta = file.getMetadata();
    file.close();
    openvdb::io::File holes((dir / "holes.vdb").string());
    holes.write(grids, *meta);
    holes.close();
  }
  try {
    TsdfVolume::read_vdb(dir / "holes.vdb");
    ADD_FAILURE() << "read a surface grid with missing voxels";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lacks voxels"), std::string::npos) << e.what();
  }

  TsdfVolume other({.voxel_size = voxel * 2});
  EXPECT_THROW(other.merge_partial(first), UsageError);
}

TEST(Tsdf, SphericalRangeMapsMergeARoom) {
  const double voxel = 0.05;
  const Mesh room = testing::box({-2, -1.5, -1.2f}, {2.5f, 1.5, 1.3f}, 10, true);
  Camera pano;
  pano.model = CameraModel::equirectangular;
  pano.width = 256;
  pano.height = 128;
  std::vector<DepthFrame> frames;
  const TriangleBvh bvh(room);
  for (double x : {0.0, 0.6}) {
    pano.cam_from_world = Rigid3{Eigen::Quaterniond::Identity(), Eigen::Vector3d(-x, 0.1, 0)};
    frames.push_back(make_depth_frame(render_depth(bvh, pano), "pano", {}));
  }
  EXPECT_EQ(frames[0].kind, DepthKind::spherical_range);
  TsdfVolume volume({.voxel_size = voxel});
  for (const auto& f : frames) volume.integrate(f);
  const Mesh merged = volume.extract_mesh();
  const MeshEvalResult eval = evaluate_mesh(merged, room, {.samples = 20000, .thresholds = {2 * voxel}});
  std::cout << "room panoramas: accuracy p90 " << eval.accuracy.p90 << ", completeness " << eval.recall[0]
            << "\n";
  EXPECT_LT(eval.accuracy.p90, voxel);
  EXPECT_GT(eval.recall[0], 0.95);
}

TEST(Tsdf, ColourAndMasksReachTheMesh) {
  const double voxel = 0.04;
  const Mesh plane = testing::ground(1.0f);
  const auto cameras = orbit(3, 1.5, 1.5, {0, 0, 0}, 64, 48, 60);
  const TriangleBvh bvh(plane);
  TsdfVolume volume({.voxel_size = voxel, .color = true});
  for (const Camera& camera : cameras) {
    cv::Mat mask(48, 64, CV_8UC1, cv::Scalar(0));
    mask.colRange(0, 32).setTo(255);                           // the left half is ignored
    cv::Mat color(48, 64, CV_8UC3, cv::Scalar(30, 120, 200));  // BGR
    volume.integrate(make_depth_frame(render_depth(bvh, camera), camera.id, {}, mask, color));
  }
  const Mesh merged = volume.extract_mesh();
  ASSERT_GT(merged.face_count(), 100u);
  ASSERT_EQ(merged.colors.size(), merged.vertex_count());
  for (const auto& c : merged.colors) {
    EXPECT_EQ(c[0], 200);
    EXPECT_EQ(c[2], 30);
  }
  // No vertex is on the ignored side of any camera... every vertex projects into the kept half of some
  // camera.
  for (const auto& p : merged.positions) {
    bool kept = false;
    for (const Camera& camera : cameras) {
      Eigen::Vector2d pixel;
      kept |= camera.project_world(p.cast<double>(), pixel) && pixel.x() >= 31.5 - 1.5;
    }
    EXPECT_TRUE(kept);
  }
}

TEST(Tsdf, MemoryLimitFailsBeforeAllocating) {
  const auto frames = frames_of(set_scene(), orbit(1, 3.0, 1.8, {0, 0, 0.2}, 96, 72, 85));
  TsdfVolume volume({.voxel_size = 0.002, .max_memory = 8 << 20});
  try {
    volume.integrate(frames[0]);
    FAIL() << "expected an out-of-memory error " << volume.leaf_count() << " " << volume.memory_bytes();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::out_of_memory);
    EXPECT_NE(std::string(e.what()).find("--max-memory"), std::string::npos) << e.what();
  }
  EXPECT_EQ(volume.leaf_count(), 0u);
}

// The estimate counts the internal nodes a sparse leaf brings (at a small voxel size, ten times the
// leaf): a budget just under what the grids then take fails (before allocating, for the first
// frame), and twice it passes.
TEST(Tsdf, MemoryEstimateCoversTheInternalNodesOfSparseLeaves) {
  const auto frames = frames_of(set_scene(), orbit(2, 3.0, 1.8, {0, 0, 0.2}, 96, 72, 85));
  for (const double voxel : {0.02, 0.001}) {
    TsdfVolume unlimited({.voxel_size = voxel});
    unlimited.integrate(frames[0]);
    const std::uint64_t after_first = unlimited.memory_bytes();
    unlimited.integrate(frames[1]);
    const std::uint64_t after_both = unlimited.memory_bytes();
    TsdfVolume first_under({.voxel_size = voxel, .max_memory = after_first * 95 / 100});
    EXPECT_THROW(first_under.integrate(frames[0]), Error) << voxel;
    EXPECT_EQ(first_under.leaf_count(), 0u);
    for (const std::uint64_t needed : {after_first, after_both}) {
      TsdfVolume under({.voxel_size = voxel, .max_memory = needed * 95 / 100});
      EXPECT_THROW(
          {
            under.integrate(frames[0]);
            under.integrate(frames[1]);
          },
          Error)
          << voxel;
      TsdfVolume over({.voxel_size = voxel, .max_memory = needed * 2});
      EXPECT_NO_THROW(over.integrate(frames[0])) << voxel;
    }
  }
}

TEST(Tsdf, BadDepthInputsAreClearErrors) {
  DepthMap empty;
  empty.camera = testing::pinhole_camera(8, 6, 10, {0, 0, -1}, {0, 0, 0});
  empty.depth = cv::Mat1f(6, 8, NAN);
  EXPECT_THROW(make_depth_frame(empty, "nan.exr", {}), InputError);
  DepthMap one = empty;
  one.depth = cv::Mat1f(6, 8, 1.0f);
  try {
    make_depth_frame(one, "d.exr", {}, cv::Mat(5, 8, CV_8UC1, cv::Scalar(0)), {}, "mask.png");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mask.png: mask is 8x5 but the depth map d.exr is 8x6"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(TsdfVolume({.voxel_size = 0}), UsageError);
  EXPECT_THROW(TsdfVolume({.voxel_size = 0.01, .truncation = 0.005}), UsageError);
  EXPECT_THROW(TsdfVolume({.voxel_size = 0.01, .truncation = 2.57}), UsageError);
  EXPECT_NO_THROW(TsdfVolume({.voxel_size = 0.01, .truncation = 2.56}));
  pg::testing::TempDir dir;
  pg::testing::write_text(dir / "not.vdb", "garbage");
  EXPECT_THROW(TsdfVolume::read_vdb(dir / "not.vdb"), InputError);
}

TEST(Tsdf, WeightsFollowTheDocumentedFactors) {
  DepthMap map;
  map.camera = testing::pinhole_camera(21, 21, 20, {0, 0, 1}, {0, 0, 0});  // looks straight down at z = 0
  map.depth = cv::Mat1f(21, 21, 1.0f);
  map.confidence = cv::Mat1f(21, 21, 0.5f);
  map.camera.quality = 0.8;
  const DepthFrame frame =
      make_depth_frame(map, "plane", {.centre_falloff = 0.5, .use_angle = false, .multiplier = 2});
  EXPECT_NEAR(frame.weight(10, 10), 2 * 0.8 * 0.5, 1e-6);
  EXPECT_NEAR(frame.weight(0, 0), 2 * 0.8 * 0.5 * (1 - 0.5 * (200.0 / 220.5)), 1e-6);
  // Angle: a plane seen head-on has cos = 1 at the centre, cos of the ray angle off-centre.
  const DepthFrame angled =
      make_depth_frame(map, "plane", {.centre_falloff = 0, .use_confidence = false, .use_quality = false});
  EXPECT_NEAR(angled.weight(10, 10), 1.0, 1e-5);
  EXPECT_NEAR(angled.weight(10, 0), 20 / std::sqrt(400.0 + 100.0), 1e-4);
}

TEST(MeshCleanup, RemovesSmallPieces) {
  Mesh mesh = testing::sphere({0, 0, 0}, 1.0f, 8, 16);
  testing::append(mesh, testing::sphere({5, 0, 0}, 0.1f, 3, 4));
  mesh.vertex_properties["confidence"].assign(mesh.vertex_count(), 1.0f);
  const std::size_t big = testing::sphere({0, 0, 0}, 1.0f, 8, 16).face_count();
  EXPECT_EQ(remove_small_components(mesh, 0, 0.5), 1u);
  EXPECT_EQ(mesh.face_count(), big);
  EXPECT_EQ(mesh.vertex_properties["confidence"].size(), mesh.vertex_count());
  for (const auto& p : mesh.positions) EXPECT_LT(p.norm(), 1.01f);
}

}  // namespace
}  // namespace pg::fusion
