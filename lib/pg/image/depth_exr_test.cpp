#include "pg/image/depth_exr.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <gtest/gtest.h>

#include <cstring>
#include <map>

#include "pg/build_info.h"
#include "pg/camera/camera_json.h"
#include "pg/core/error.h"
#include "pg/image/image_io.h"
#include "pg/testing/testing.h"

namespace fs = std::filesystem;

namespace pg {
namespace {

constexpr float nan_value = std::numeric_limits<float>::quiet_NaN();

Camera test_camera(int width = 8, int height = 6) {
  Camera camera;
  camera.id = "cam0";
  camera.image = "images/cam0.png";
  camera.width = width;
  camera.height = height;
  camera.intrinsics = {9.5, 10.25, 3.4, 2.6};
  camera.cam_from_world.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  camera.cam_from_world.translation = Eigen::Vector3d(0.5, -0.25, 2.0);
  return camera;
}

DepthMap test_map() {
  DepthMap map;
  map.camera = test_camera();
  map.kind = DepthKind::spherical_range;
  map.depth.create(6, 8, CV_32FC1);
  map.confidence.create(6, 8, CV_32FC1);
  map.normals.create(6, 8, CV_32FC3);
  map.mask = cv::Mat::zeros(6, 8, CV_8UC1);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) {
      map.depth.at<float>(y, x) = 1.0f + 0.1234567f * x + 1e-7f * y * y;
      map.confidence.at<float>(y, x) = (x + 8 * y) / 47.f;
      map.normals.at<cv::Vec3f>(y, x) = cv::normalize(cv::Vec3f(0.1f * x, -0.2f * y, -1.f));
    }
  map.depth.at<float>(0, 0) = nan_value;
  map.depth.at<float>(3, 5) = nan_value;
  map.depth.at<float>(5, 7) = std::numeric_limits<float>::denorm_min();
  map.normals.at<cv::Vec3f>(3, 5) = cv::Vec3f(nan_value, nan_value, nan_value);
  map.mask.at<uchar>(2, 2) = 255;
  map.mask.at<uchar>(4, 6) = 255;
  map.provenance.tool = "pg-test";
  map.provenance.version = "0.1.0";
  map.provenance.command_line = "pg-test --flag \"quoted\"";
  map.provenance.created_utc = "2024-01-02T03:04:05Z";
  map.provenance.inputs = {"a.exr", "b.json"};
  return map;
}

bool bit_identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) return false;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  return true;
}

// Writes an EXR with OpenEXR directly: channels of any pixel type filled with `value`, string attributes,
// and an arbitrary data window. With write_pixels false only the header and offset table are written.
struct RawExr {
  Imath::Box2i window{Imath::V2i(0, 0), Imath::V2i(7, 5)};
  std::vector<std::pair<std::string, Imf::PixelType>> channels = {{"Z", Imf::FLOAT}};
  std::map<std::string, std::string> strings;
  float value = 2.0f;
  bool write_pixels = true;

  void write(const fs::path& path) const {
    Imf::Header header(window, window);
    for (const auto& [name, text] : strings) header.insert(name, Imf::StringAttribute(text));
    for (const auto& [name, type] : channels) header.channels().insert(name, Imf::Channel(type));
    Imf::OutputFile out(path.c_str(), header);
    if (!write_pixels) return;
    const int width = window.max.x - window.min.x + 1, height = window.max.y - window.min.y + 1;
    std::vector<float> floats(static_cast<std::size_t>(width) * height, value);
    std::vector<half> halves(floats.size(), half(value));
    std::vector<unsigned> uints(floats.size(), static_cast<unsigned>(value));
    Imf::FrameBuffer buffer;
    for (const auto& [name, type] : channels) {
      char* base = type == Imf::FLOAT  ? reinterpret_cast<char*>(floats.data())
                   : type == Imf::HALF ? reinterpret_cast<char*>(halves.data())
                                       : reinterpret_cast<char*>(uints.data());
      const std::size_t element = type == Imf::HALF ? 2 : 4;
      base -= (window.min.x + static_cast<std::ptrdiff_t>(window.min.y) * width) * element;
      buffer.insert(name, Imf::Slice(type, base, element, element * width));
    }
    out.setFrameBuffer(buffer);
    out.writePixels(height);
  }
};

std::map<std::string, std::string> pg_header(const Camera& camera = test_camera()) {
  return {{"pg/format", "pg-depth-exr"},
          {"pg/version", "1"},
          {"pg/depthKind", "perspective_z"},
          {"pg/camera", camera_to_json(camera).dump()},
          {"pg/provenance", R"({"tool":"crafted"})"}};
}

template <typename Reader>
void expect_refused_by(Reader read, const fs::path& path, const std::string& fragment) {
  try {
    read(path);
    ADD_FAILURE() << "no error for " << path << " (expected '" << fragment << "')";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

void expect_rejected(const fs::path& path, const std::string& fragment) {
  expect_refused_by(read_depth_exr, path, fragment);
}

// A problem in the header: the header reader refuses the file with the same message.
void expect_header_rejected(const fs::path& path, const std::string& fragment) {
  expect_refused_by(read_depth_exr, path, fragment);
  expect_refused_by(read_depth_exr_header, path, fragment);
}

TEST(DepthExr, RoundTripKeepsEveryChannelBitExactAndTheHeader) {
  testing::TempDir dir;
  const DepthMap map = test_map();
  write_depth_exr(dir / "depth.exr", map);
  const DepthExrHeader header = read_depth_exr_header(dir / "depth.exr");
  EXPECT_EQ(header.kind, DepthKind::spherical_range);
  EXPECT_EQ(camera_to_json(header.camera), camera_to_json(map.camera));
  EXPECT_EQ(to_json(header.provenance), to_json(map.provenance));
  const DepthMap back = read_depth_exr(dir / "depth.exr");
  EXPECT_TRUE(bit_identical(back.depth, map.depth));  // NaN pattern, denormals and all
  EXPECT_TRUE(std::isnan(back.depth.at<float>(3, 5)));
  EXPECT_TRUE(bit_identical(back.confidence, map.confidence));
  EXPECT_TRUE(bit_identical(back.normals, map.normals));
  EXPECT_TRUE(bit_identical(back.mask, map.mask));
  EXPECT_EQ(back.kind, DepthKind::spherical_range);
  EXPECT_EQ(camera_to_json(back.camera), camera_to_json(map.camera));
  EXPECT_EQ(to_json(back.provenance), to_json(map.provenance));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()),
            1);  // no temporaries
}

TEST(DepthExr, OptionalChannelsStayEmptyAndFileUsesFloatZipChannels) {
  testing::TempDir dir;
  DepthMap map = test_map();
  map.kind = DepthKind::perspective_z;
  map.confidence.release();
  map.normals.release();
  map.mask.release();
  write_depth_exr(dir / "plain.exr", map);
  const DepthMap back = read_depth_exr(dir / "plain.exr");
  EXPECT_TRUE(back.confidence.empty() && back.normals.empty() && back.mask.empty());
  EXPECT_EQ(back.kind, DepthKind::perspective_z);

  write_depth_exr(dir / "full.exr", test_map());
  Imf::InputFile file((dir / "full.exr").c_str());
  EXPECT_EQ(file.header().compression(), Imf::ZIP_COMPRESSION);
  std::vector<std::string> names;
  for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
    names.push_back(it.name());
    EXPECT_EQ(it.channel().type, Imf::FLOAT);
  }
  EXPECT_EQ(names, std::vector<std::string>({"N.x", "N.y", "N.z", "Z", "confidence", "mask"}));
}

TEST(DepthExr, StandardCameraMatricesAgreeWithTheCameraModel) {
  testing::TempDir dir;
  DepthMap map = test_map();
  map.kind = DepthKind::perspective_z;
  write_depth_exr(dir / "depth.exr", map);
  Imf::InputFile file((dir / "depth.exr").c_str());
  ASSERT_TRUE(Imf::hasWorldToCamera(file.header()));
  ASSERT_TRUE(Imf::hasWorldToNDC(file.header()));
  const Imath::M44f world_to_camera = Imf::worldToCamera(file.header());
  const Imath::M44f world_to_ndc = Imf::worldToNDC(file.header());
  const Camera& camera = map.camera;
  for (const Eigen::Vector3d& world : {Eigen::Vector3d(0.1, 0.2, 1.5), Eigen::Vector3d(-0.4, 0.3, 3.0)}) {
    const Imath::V3f p(static_cast<float>(world.x()), static_cast<float>(world.y()),
                       static_cast<float>(world.z()));
    // OpenEXR camera space: x right, y up, z forward (ours has y down).
    Imath::V3f in_camera;
    world_to_camera.multVecMatrix(p, in_camera);
    const Eigen::Vector3d expected = camera.cam_from_world * world;
    EXPECT_NEAR(in_camera.x, expected.x(), 1e-5);
    EXPECT_NEAR(in_camera.y, -expected.y(), 1e-5);
    EXPECT_NEAR(in_camera.z, expected.z(), 1e-5);
    // NDC (0, 0) is the top-left corner of the image, (1, 1) the bottom-right one.
    Imath::V3f ndc;
    world_to_ndc.multVecMatrix(p, ndc);
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.project_world(world, pixel));
    EXPECT_NEAR(ndc.x * camera.width - 0.5, pixel.x(), 1e-4);
    EXPECT_NEAR(ndc.y * camera.height - 0.5, pixel.y(), 1e-4);
  }
  // A distorted camera gets worldToCamera only.
  map.camera.distortion.k1 = 0.1;
  write_depth_exr(dir / "distorted.exr", map);
  Imf::InputFile distorted((dir / "distorted.exr").c_str());
  EXPECT_TRUE(Imf::hasWorldToCamera(distorted.header()));
  EXPECT_FALSE(Imf::hasWorldToNDC(distorted.header()));
}

TEST(DepthExr, HalfChannelsAreConvertedToFloat) {
  testing::TempDir dir;
  RawExr raw;
  raw.channels = {{"Z", Imf::HALF}, {"confidence", Imf::HALF}};
  raw.strings = pg_header();
  raw.value = 1.5f;  // exactly representable in half
  raw.write(dir / "half.exr");
  const DepthMap map = read_depth_exr(dir / "half.exr");
  EXPECT_EQ(map.depth.type(), CV_32FC1);
  EXPECT_EQ(cv::countNonZero(map.depth != 1.5f), 0);
  EXPECT_EQ(cv::countNonZero(map.confidence != 1.5f), 0);
}

TEST(DepthExr, RejectsFilesThatDoNotFollowTheFormat) {
  testing::TempDir dir;
  expect_header_rejected(dir / "absent.exr", "does not exist");
  testing::write_text(dir / "text.exr", "not an EXR at all");
  expect_header_rejected(dir / "text.exr", "not a readable OpenEXR file");

  RawExr raw;
  raw.strings = pg_header();
  auto variant = [&](const std::string& name, auto change) {
    RawExr copy = raw;
    change(copy);
    copy.write(dir / name);
    return dir / name;
  };
  expect_header_rejected(variant("plain.exr", [](RawExr& r) { r.strings.clear(); }), "no pg/format");
  expect_header_rejected(variant("format.exr", [](RawExr& r) { r.strings["pg/format"] = "pg-mesh"; }),
                         "expected 'pg-depth-exr'");
  expect_header_rejected(variant("version.exr", [](RawExr& r) { r.strings["pg/version"] = "99"; }),
                         "unsupported pg/version '99'");
  expect_header_rejected(variant("version-text.exr", [](RawExr& r) { r.strings["pg/version"] = "1.0"; }),
                         "unsupported pg/version '1.0'");
  expect_header_rejected(variant("no-version.exr", [](RawExr& r) { r.strings.erase("pg/version"); }),
                         "pg/version");
  expect_header_rejected(variant("no-z.exr",
                                 [](RawExr& r) {
                                   r.channels = {{"Y", Imf::FLOAT}};
                                 }),
                         "missing channel 'Z'");
  expect_header_rejected(variant("uint.exr",
                                 [](RawExr& r) {
                                   r.channels = {{"Z", Imf::UINT}};
                                 }),
                         "pixel type UINT");
  expect_header_rejected(variant("normals.exr",
                                 [](RawExr& r) {
                                   r.channels = {{"Z", Imf::FLOAT}, {"N.x", Imf::FLOAT}};
                                 }),
                         "incomplete normals");
  expect_header_rejected(
      variant("size.exr",
              [](RawExr& r) { r.strings["pg/camera"] = camera_to_json(test_camera(9, 6)).dump(); }),
      "data window is 8 x 6");
  expect_header_rejected(variant("json.exr", [](RawExr& r) { r.strings["pg/camera"] = "{\"id\": "; }),
                         "pg/camera is not a JSON object");
  expect_header_rejected(variant("model.exr",
                                 [](RawExr& r) {
                                   nlohmann::json camera = camera_to_json(test_camera());
                                   camera["model"] = "orthographic";
                                   r.strings["pg/camera"] = camera.dump();
                                 }),
                         "pg/camera");
  expect_header_rejected(variant("kind.exr", [](RawExr& r) { r.strings["pg/depthKind"] = "disparity"; }),
                         "pg/depthKind is 'disparity'");
  expect_header_rejected(variant("provenance.exr", [](RawExr& r) { r.strings["pg/provenance"] = "[1, 2]"; }),
                         "pg/provenance is not a JSON object");
  // Provenance is informational: a field of the wrong type is skipped, not a reason to refuse the depth.
  EXPECT_EQ(read_depth_exr(
                variant("provenance-type.exr",
                        [](RawExr& r) { r.strings["pg/provenance"] = R"({"tool": 5, "version": "1"})"; }))
                .provenance.version,
            "1");
  expect_header_rejected(variant("equirect.exr",
                                 [](RawExr& r) {
                                   Camera camera = test_camera();
                                   camera.model = CameraModel::equirectangular;
                                   r.strings["pg/camera"] = camera_to_json(camera).dump();
                                 }),
                         "perspective_z depth with an equirectangular camera");
}

TEST(DepthExr, RejectsHugeDataWindowsBeforeAllocating) {
  testing::TempDir dir;
  // Headers claiming 20000 x 20000 (4e8 pixels) and 70000 x 1 with no pixel data: a few kilobytes on
  // disk; reading them must fail from the header alone.
  RawExr area;
  area.strings = pg_header(test_camera(20000, 20000));
  area.window = Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(19999, 19999));
  area.write_pixels = false;
  area.write(dir / "area.exr");
  EXPECT_LT(fs::file_size(dir / "area.exr"), 100000u);
  expect_rejected(dir / "area.exr", "exceeds the limit");

  RawExr side = area;
  side.window = Imath::Box2i(Imath::V2i(-5, 0), Imath::V2i(69994, 0));
  side.write(dir / "side.exr");
  expect_rejected(dir / "side.exr", "70000 x 1");
  EXPECT_FALSE(is_pg_depth_exr(dir / "side.exr"));  // the header check runs before anything is sized
}

// A header that OpenEXR's core library and Imf::InputFile read differently (found by fuzz_depth_exr:
// InputFile saw a 33423056 x 29185 window and allocated 2 GB for one chunk of lines).
TEST(DepthExr, WindowIsCheckedAsOpenExrItselfReadsIt) {
  const fs::path file = fs::path(build_info::source_dir) / "testdata" / "fuzz-regressions" / "depth_exr" /
                        "box2i-wrong-size-huge-window.exr";
  expect_rejected(file, "33423056 x 29185 pixels exceeds the limit");
  EXPECT_FALSE(is_pg_depth_exr(file));
}

TEST(DepthExr, PgDepthFilesAreToldFromPlainExrs) {
  testing::TempDir dir;
  write_depth_exr(dir / "depth.exr", test_map());
  write_image(dir / "plain.exr", cv::Mat1f(4, 6, 1.f));
  testing::write_text(dir / "text.exr", "not an EXR");
  EXPECT_TRUE(is_pg_depth_exr(dir / "depth.exr"));
  EXPECT_FALSE(is_pg_depth_exr(dir / "plain.exr"));
  EXPECT_FALSE(is_pg_depth_exr(dir / "text.exr"));
  EXPECT_FALSE(is_pg_depth_exr(dir / "absent.exr"));
}

TEST(DepthExr, RejectsTruncatedAndIncompleteFiles) {
  testing::TempDir dir;
  write_depth_exr(dir / "good.exr", test_map());
  const std::string bytes = testing::read_text(dir / "good.exr");
  for (std::size_t keep : {std::size_t{20}, bytes.size() / 2, bytes.size() - 10}) {
    testing::write_text(dir / "cut.exr", bytes.substr(0, keep));
    EXPECT_THROW(read_depth_exr(dir / "cut.exr"), InputError) << "kept " << keep << " bytes";
  }
  RawExr empty;
  empty.strings = pg_header();
  empty.write_pixels = false;
  empty.write(dir / "empty.exr");
  expect_rejected(dir / "empty.exr", "incomplete");
}

TEST(DepthExr, ForeignFilesAreReadFromZOrY) {
  testing::TempDir dir;
  RawExr raw;
  raw.channels = {{"Y", Imf::FLOAT}};
  raw.value = 3.25f;
  raw.window = Imath::Box2i(Imath::V2i(10, 20), Imath::V2i(17, 25));  // offset data window
  raw.write(dir / "y.exr");
  const DepthMap map = read_depth_exr_foreign(dir / "y.exr", test_camera(), DepthKind::perspective_z);
  EXPECT_EQ(map.depth.size(), cv::Size(8, 6));
  EXPECT_EQ(cv::countNonZero(map.depth != 3.25f), 0);
  EXPECT_EQ(map.provenance.inputs, std::vector<std::string>({(dir / "y.exr").string()}));

  // Zero means "no depth" in many tools: it becomes NaN.
  raw.channels = {{"Z", Imf::FLOAT}, {"R", Imf::FLOAT}};
  raw.value = 0.f;
  raw.write(dir / "z.exr");
  const DepthMap zeros = read_depth_exr_foreign(dir / "z.exr", test_camera(), DepthKind::spherical_range);
  EXPECT_EQ(cv::countNonZero(zeros.depth == zeros.depth), 0);  // all NaN
  EXPECT_EQ(zeros.kind, DepthKind::spherical_range);

  EXPECT_THROW(read_depth_exr_foreign(dir / "z.exr", test_camera(9, 6), DepthKind::perspective_z),
               InputError);
  raw.channels = {{"R", Imf::FLOAT}};
  raw.write(dir / "r.exr");
  EXPECT_THROW(read_depth_exr_foreign(dir / "r.exr", test_camera(), DepthKind::perspective_z), InputError);
  // A pg file is a valid foreign file too.
  write_depth_exr(dir / "pg.exr", test_map());
  const DepthMap pg = read_depth_exr_foreign(dir / "pg.exr", test_camera(), DepthKind::spherical_range);
  EXPECT_EQ(cv::countNonZero(pg.depth == pg.depth), 46);  // two NaN; the denormal is positive and kept
}

TEST(DepthExr, WriterRefusesInconsistentMaps) {
  testing::TempDir dir;
  auto refused = [&](auto change) {
    DepthMap map = test_map();
    change(map);
    EXPECT_THROW(write_depth_exr(dir / "bad.exr", map), OutputError);
  };
  refused([](DepthMap& m) { m.depth.release(); });
  refused([](DepthMap& m) { m.depth.convertTo(m.depth, CV_64F); });
  refused([](DepthMap& m) { m.camera.width = 9; });
  refused([](DepthMap& m) { m.confidence = cv::Mat(3, 3, CV_32FC1); });
  refused([](DepthMap& m) { m.normals = cv::Mat(6, 8, CV_32FC1); });
  refused([](DepthMap& m) { m.mask = cv::Mat(6, 8, CV_32FC1); });
  refused([](DepthMap& m) {
    m.camera.model = CameraModel::equirectangular;
    m.kind = DepthKind::perspective_z;
  });
  EXPECT_FALSE(fs::exists(dir / "bad.exr"));
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(DepthExr, PreviewIsWarmNearCoolFarAndBlackWhereInvalid) {
  testing::TempDir dir;
  DepthMap map = test_map();
  map.depth.setTo(5.f);
  map.depth.colRange(0, 4).setTo(1.f);  // near half
  map.depth.at<float>(0, 7) = nan_value;
  map.mask.setTo(0);
  write_depth_preview_png(dir / "preview.png", map);
  const cv::Mat preview = read_image(dir / "preview.png");
  ASSERT_EQ(preview.type(), CV_8UC3);
  const cv::Vec3b near = preview.at<cv::Vec3b>(3, 1), far = preview.at<cv::Vec3b>(3, 6);
  EXPECT_GT(near[2], near[0]);  // red over blue
  EXPECT_GT(far[0], far[2]);    // blue over red
  EXPECT_EQ(preview.at<cv::Vec3b>(0, 7), cv::Vec3b(0, 0, 0));
}

// The worked example of formats/depth-exr.md: an identity-pose 8 x 6 pinhole camera looking at the plane
// z = 2 + 0.5 y (world = camera frame), so depth(u, v) = 2 / (1 - 0.5 (v - cy) / fy); pixel (0, 0) invalid,
// the right column masked. Set PG_WRITE_EXAMPLES=1 to regenerate the files under formats/examples/.
DepthMap documented_example() {
  DepthMap map;
  map.camera.id = "example";
  map.camera.image = "example.png";
  map.camera.width = 8;
  map.camera.height = 6;
  map.camera.intrinsics = {8.0, 8.0, 3.5, 2.5};
  map.depth.create(6, 8, CV_32FC1);
  map.confidence.create(6, 8, CV_32FC1);
  map.normals.create(6, 8, CV_32FC3);
  map.mask = cv::Mat::zeros(6, 8, CV_8UC1);
  const cv::Vec3f normal = cv::normalize(cv::Vec3f(0.f, 0.5f, -1.f));  // facing the camera
  for (int v = 0; v < 6; ++v)
    for (int u = 0; u < 8; ++u) {
      map.depth.at<float>(v, u) = static_cast<float>(2.0 / (1.0 - 0.5 * (v - 2.5) / 8.0));
      map.confidence.at<float>(v, u) = 1.f;
      map.normals.at<cv::Vec3f>(v, u) = normal;
    }
  map.depth.at<float>(0, 0) = nan_value;
  map.confidence.at<float>(0, 0) = 0.f;
  map.normals.at<cv::Vec3f>(0, 0) = cv::Vec3f(nan_value, nan_value, nan_value);
  map.mask.col(7).setTo(255);
  map.provenance.tool = "pg_image_tests";
  map.provenance.version = "0.1.0";
  map.provenance.command_line =
      "PG_WRITE_EXAMPLES=1 pg_image_tests --gtest_filter=DepthExr.DocumentedExample*";
  map.provenance.created_utc = "2024-01-01T00:00:00Z";
  return map;
}

TEST(DepthExr, DocumentedExampleReadsBack) {
  const fs::path examples = fs::path(build_info::source_dir) / "formats" / "examples";
  if (std::getenv("PG_WRITE_EXAMPLES")) {
    write_depth_exr(examples / "depth-8x6.exr", documented_example());
    write_depth_preview_png(examples / "depth-8x6-preview.png", documented_example());
  }
  const DepthMap expected = documented_example();
  const DepthMap map = read_depth_exr(examples / "depth-8x6.exr");
  EXPECT_TRUE(bit_identical(map.depth, expected.depth));
  EXPECT_TRUE(bit_identical(map.confidence, expected.confidence));
  EXPECT_TRUE(bit_identical(map.normals, expected.normals));
  EXPECT_TRUE(bit_identical(map.mask, expected.mask));
  EXPECT_EQ(map.kind, DepthKind::perspective_z);
  EXPECT_EQ(camera_to_json(map.camera), camera_to_json(expected.camera));
  EXPECT_EQ(map.provenance.created_utc, "2024-01-01T00:00:00Z");
  // Independent check of the geometry: the back-projected pixel lies on the plane z = 2 + 0.5 y.
  for (int v = 0; v < 6; ++v)
    for (int u = 1; u < 8; ++u) {
      const double z = map.depth.at<float>(v, u), y = (v - 2.5) / 8.0 * z;
      EXPECT_NEAR(z, 2.0 + 0.5 * y, 1e-6);
    }
}

}  // namespace
}  // namespace pg
