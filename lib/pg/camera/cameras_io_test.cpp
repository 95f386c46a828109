// The cameras file: bit-exact round trips and every rejection naming the file.
#include "pg/camera/cameras_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <random>

#include "pg/build_info.h"
#include "pg/camera/camera_json.h"
#include "pg/core/error.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

using nlohmann::json;

// Doubles with random bits in every position of the mantissa, of mixed signs and magnitudes.
double random_double(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-1, 1);
  const double mantissa = u(rng);  // one draw per statement: argument order is unspecified
  return scale * mantissa * std::pow(10.0, double(std::uniform_int_distribution<int>(-3, 3)(rng)));
}

CameraSet random_set(std::mt19937_64& rng) {
  CameraSet set;
  const CameraModel models[] = {CameraModel::pinhole, CameraModel::fisheye, CameraModel::equirectangular};
  for (int i = 0; i < 9; ++i) {
    Camera c;
    c.id = "cam" + std::to_string(i);
    c.image = "images/frame_" + std::to_string(i) + ".exr";
    c.model = models[i % 3];
    c.width = 1000 + i;
    c.height = 700 + 3 * i;
    if (c.is_perspective()) {
      std::uniform_real_distribution<double> f(300, 3000);
      c.intrinsics = {f(rng), f(rng), random_double(rng, 1000), random_double(rng, 1000)};
      c.distortion.k1 = random_double(rng, 0.1);
      c.distortion.k2 = random_double(rng, 0.1);
      c.distortion.k3 = random_double(rng, 0.1);
      c.distortion.k4 = random_double(rng, 0.1);
      if (c.model == CameraModel::pinhole) {
        c.distortion.k5 = random_double(rng, 0.1);
        c.distortion.k6 = random_double(rng, 0.1);
        c.distortion.p1 = random_double(rng, 0.01);
        c.distortion.p2 = random_double(rng, 0.01);
      }
    }
    std::normal_distribution<double> n(0, 1);
    c.cam_from_world.rotation = Eigen::Quaterniond{n(rng), n(rng), n(rng), n(rng)}.normalized();
    c.cam_from_world.translation = {random_double(rng, 10), random_double(rng, 10), random_double(rng, 10)};
    if (i % 2) c.quality = std::uniform_real_distribution<double>(0, 1)(rng);
    if (i == 4) {
      std::array<double, 12> stddev;
      for (double& s : stddev) s = std::abs(random_double(rng, 1));
      c.stddev = stddev;
    }
    set.cameras.push_back(c);
  }
  set.cameras[2].rig = "pano_pair";
  set.cameras[5].rig = "pano_pair";
  set.rigs.push_back({"pano_pair", {"cam2", "cam5"}, Eigen::Vector3d(0, -0.27, 0)});
  set.rigs.push_back({"stereo", {"cam0", "cam3", "cam6"}, std::nullopt});
  return set;
}

bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

void expect_same_camera(const Camera& a, const Camera& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.image, b.image);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.model, b.model);
  const double lhs[] = {a.intrinsics.fx,
                        a.intrinsics.fy,
                        a.intrinsics.cx,
                        a.intrinsics.cy,
                        a.distortion.k1,
                        a.distortion.k2,
                        a.distortion.p1,
                        a.distortion.p2,
                        a.distortion.k3,
                        a.distortion.k4,
                        a.distortion.k5,
                        a.distortion.k6,
                        a.cam_from_world.rotation.x(),
                        a.cam_from_world.rotation.y(),
                        a.cam_from_world.rotation.z(),
                        a.cam_from_world.rotation.w(),
                        a.cam_from_world.translation.x(),
                        a.cam_from_world.translation.y(),
                        a.cam_from_world.translation.z()};
  const double rhs[] = {b.intrinsics.fx,
                        b.intrinsics.fy,
                        b.intrinsics.cx,
                        b.intrinsics.cy,
                        b.distortion.k1,
                        b.distortion.k2,
                        b.distortion.p1,
                        b.distortion.p2,
                        b.distortion.k3,
                        b.distortion.k4,
                        b.distortion.k5,
                        b.distortion.k6,
                        b.cam_from_world.rotation.x(),
                        b.cam_from_world.rotation.y(),
                        b.cam_from_world.rotation.z(),
                        b.cam_from_world.rotation.w(),
                        b.cam_from_world.translation.x(),
                        b.cam_from_world.translation.y(),
                        b.cam_from_world.translation.z()};
  for (std::size_t i = 0; i < std::size(lhs); ++i)
    EXPECT_TRUE(same_bits(lhs[i], rhs[i])) << a.id << " value " << i;
  EXPECT_EQ(a.quality.has_value(), b.quality.has_value());
  if (a.quality && b.quality) {
    EXPECT_TRUE(same_bits(*a.quality, *b.quality));
  }
  EXPECT_EQ(a.rig, b.rig);
  EXPECT_EQ(a.stddev.has_value(), b.stddev.has_value());
  if (a.stddev && b.stddev) {
    for (std::size_t i = 0; i < 12; ++i) EXPECT_TRUE(same_bits((*a.stddev)[i], (*b.stddev)[i]));
  }
}

TEST(CamerasFile, RoundTripIsBitExact) {
  testing::TempDir dir;
  std::mt19937_64 rng(21);
  const CameraSet set = random_set(rng);
  write_cameras(dir / "cameras.json", set);
  const CameraSet back = read_cameras(dir / "cameras.json");
  ASSERT_EQ(back.cameras.size(), set.cameras.size());
  for (std::size_t i = 0; i < set.cameras.size(); ++i) expect_same_camera(set.cameras[i], back.cameras[i]);
  ASSERT_EQ(back.rigs.size(), 2u);
  EXPECT_EQ(back.rigs[0].id, "pano_pair");
  EXPECT_EQ(back.rigs[0].camera_ids, (std::vector<std::string>{"cam2", "cam5"}));
  ASSERT_TRUE(back.rigs[0].offset.has_value());
  EXPECT_EQ(*back.rigs[0].offset, Eigen::Vector3d(0, -0.27, 0));
  EXPECT_FALSE(back.rigs[1].offset.has_value());
  EXPECT_EQ(back.find("cam4")->id, "cam4");
  EXPECT_EQ(back.find("nope"), nullptr);
  // Writing what was read gives the same bytes (the provenance is kept as read).
  write_cameras(dir / "again.json", back);
  EXPECT_EQ(testing::read_text(dir / "cameras.json"), testing::read_text(dir / "again.json"));
}

TEST(CamerasFile, SingleCameraJsonRoundTrip) {
  std::mt19937_64 rng(22);
  for (const Camera& c : random_set(rng).cameras) {
    expect_same_camera(c, camera_from_json(camera_to_json(c), "header.exr", "depth header"));
    expect_same_camera(c, camera_from_json(json::parse(camera_to_ordered_json(c).dump()), "x", ""));
  }
}

TEST(CamerasFile, HeaderComesFirstAndProvenanceIsFilled) {
  testing::TempDir dir;
  CameraSet set;
  Camera c;
  c.id = "a";
  c.width = c.height = 10;
  c.intrinsics = {10, 10, 5, 5};
  set.cameras.push_back(c);
  write_cameras(dir / "c.json", set);
  const std::string text = testing::read_text(dir / "c.json");
  const auto format = text.find("\"format\""), version = text.find("\"version\""),
             provenance = text.find("\"provenance\""), cameras = text.find("\"cameras\"");
  EXPECT_LT(format, version);
  EXPECT_LT(version, provenance);
  EXPECT_LT(provenance, cameras);
  const CameraSet back = read_cameras(dir / "c.json");
  EXPECT_EQ(back.provenance.tool, Provenance::current().tool);
  EXPECT_FALSE(back.provenance.created_utc.empty());
  EXPECT_EQ(json::parse(text)["format"], "pg-cameras");
  EXPECT_EQ(json::parse(text)["version"], 1);
}

TEST(CamerasFile, WriterRefusesSetsThatWouldNotReadBack) {
  testing::TempDir dir;
  std::mt19937_64 rng(23);
  CameraSet set = random_set(rng);
  set.cameras[1].id = "cam0";
  EXPECT_THROW(write_cameras(dir / "dup.json", set), OutputError);
  EXPECT_FALSE(std::filesystem::exists(dir / "dup.json"));
  set = random_set(rng);
  set.cameras[0].intrinsics.fx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(write_cameras(dir / "nan.json", set), OutputError);
}

TEST(CamerasFile, ExampleFileReads) {
  const auto example = std::filesystem::path(build_info::source_dir) / "formats/examples/cameras.json";
  const CameraSet set = read_cameras(example);
  EXPECT_GE(set.cameras.size(), 3u);
  EXPECT_FALSE(set.rigs.empty());
}

// A small valid document; each rejection case edits one thing.
json valid_document() {
  std::mt19937_64 rng(24);
  CameraSet set = random_set(rng);
  return json::parse(cameras_to_json(set).dump());
}

struct Rejection {
  const char* name;
  std::function<void(json&)> edit;
  const char* expected;  // a substring the message must contain besides the path
};

TEST(CamerasFile, RejectionsNameTheFileAndTheCulprit) {
  const Rejection cases[] = {
      {"wrong format", [](json& d) { d["format"] = "pg-tracks"; }, "pg-tracks"},
      {"newer version", [](json& d) { d["version"] = 2; }, "version 2"},
      {"unknown top-level field", [](json& d) { d["lenses"] = json::array(); }, "lenses"},
      {"missing provenance", [](json& d) { d.erase("provenance"); }, "provenance"},
      {"missing cameras", [](json& d) { d.erase("cameras"); }, "cameras"},
      {"unknown camera field", [](json& d) { d["cameras"][1]["focal"] = 3; },
       "camera \"cam1\": unknown field \"focal\""},
      {"missing field", [](json& d) { d["cameras"][0]["intrinsics"].erase("fx"); },
       "camera \"cam0\".intrinsics: missing \"fx\""},
      {"missing id", [](json& d) { d["cameras"][3].erase("id"); }, "cameras[3]: missing \"id\""},
      {"unknown model", [](json& d) { d["cameras"][0]["model"] = "kannala"; }, "kannala"},
      {"zero width", [](json& d) { d["cameras"][0]["width"] = 0; }, "camera \"cam0\": image size 0x700"},
      {"huge height", [](json& d) { d["cameras"][0]["height"] = 70000; }, "outside 1..65536"},
      {"fractional width", [](json& d) { d["cameras"][0]["width"] = 100.5; }, "\"width\" is not an integer"},
      {"negative focal", [](json& d) { d["cameras"][1]["intrinsics"]["fy"] = -5; },
       "camera \"cam1\".intrinsics: focal"},
      {"string number", [](json& d) { d["cameras"][0]["intrinsics"]["cx"] = "960"; },
       "\"cx\" is not a number"},
      {"unnormalised quaternion",
       [](json& d) {
         d["cameras"][4]["cam_from_world"]["rotation_xyzw"] = {0, 0, 0, 1.01};
       },
       "camera \"cam4\".cam_from_world: \"rotation_xyzw\" has norm"},
      {"short quaternion",
       [](json& d) {
         d["cameras"][4]["cam_from_world"]["rotation_xyzw"] = {0, 0, 1};
       },
       "\"rotation_xyzw\" has 3 values, expected 4"},
      {"short translation",
       [](json& d) {
         d["cameras"][2]["cam_from_world"]["translation"] = {0, 1};
       },
       "camera \"cam2\".cam_from_world: \"translation\" has 2 values"},
      {"quality above one", [](json& d) { d["cameras"][1]["quality"] = 1.5; },
       "camera \"cam1\": \"quality\""},
      {"short stddev", [](json& d) { d["cameras"][4]["stddev"] = std::vector<double>(11, 0.1); },
       "\"stddev\" has 11"},
      {"null quality", [](json& d) { d["cameras"][1]["quality"] = nullptr; }, "\"quality\" is not a number"},
      {"negative stddev", [](json& d) { d["cameras"][4]["stddev"][3] = -1; }, "negative"},
      {"pinhole coefficient on fisheye", [](json& d) { d["cameras"][1]["distortion"]["p1"] = 0; },
       "camera \"cam1\".distortion: unknown field \"p1\""},
      {"intrinsics on equirectangular",
       [](json& d) {
         d["cameras"][2]["intrinsics"] = {{"fx", 1}};
       },
       "camera \"cam2\": unknown field \"intrinsics\""},
      {"duplicate id", [](json& d) { d["cameras"][7]["id"] = "cam3"; }, "duplicate camera id \"cam3\""},
      {"rig names unknown camera", [](json& d) { d["rigs"][1]["cameras"][2] = "cam99"; },
       "rig \"stereo\": names unknown camera \"cam99\""},
      {"camera in two rigs", [](json& d) { d["rigs"][1]["cameras"][2] = "cam5"; }, "already in rig"},
      {"camera names unknown rig", [](json& d) { d["cameras"][8]["rig"] = "tripod"; },
       "camera \"cam8\": rig \"tripod\""},
      {"offset on three cameras",
       [](json& d) {
         d["rigs"][1]["offset"] = {1, 0, 0};
       },
       "exactly two cameras"},
      {"short offset",
       [](json& d) {
         d["rigs"][0]["offset"] = {1, 0};
       },
       "rig \"pano_pair\": \"offset\" has 2"},
      {"unknown rig field", [](json& d) { d["rigs"][0]["baseline"] = 1; },
       "rig \"pano_pair\": unknown field"},
  };
  testing::TempDir dir;
  for (const Rejection& r : cases) {
    json doc = valid_document();
    r.edit(doc);
    const auto path = dir / "bad.json";
    testing::write_text(path, doc.dump(2));
    try {
      read_cameras(path);
      ADD_FAILURE() << r.name << ": accepted";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << r.name << ": " << message;
      EXPECT_NE(message.find(r.expected), std::string::npos) << r.name << ": " << message;
      EXPECT_EQ(e.file(), path);
    }
  }
}

TEST(CamerasFile, RejectsNonFiniteAndMalformedText) {
  testing::TempDir dir;
  std::string text = valid_document().dump(2);
  const std::string fx = "\"fx\": ";
  const auto at = text.find(fx) + fx.size();
  text.replace(at, text.find(',', at) - at, "1e999");  // overflows a double
  testing::write_text(dir / "inf.json", text);
  try {
    read_cameras(dir / "inf.json");
    ADD_FAILURE() << "accepted an infinite focal length";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir / "inf.json").string() + ": ", 0), 0u) << e.what();
  }
  testing::write_text(dir / "truncated.json", valid_document().dump().substr(0, 200));
  EXPECT_THROW(read_cameras(dir / "truncated.json"), InputError);
  EXPECT_THROW(read_cameras(dir / "missing.json"), InputError);
  // JSON text cannot hold NaN, but an in-memory document (an EXR header being built) can.
  std::mt19937_64 rng(26);
  nlohmann::json j = camera_to_json(random_set(rng).cameras[0]);
  j["cam_from_world"]["translation"][1] = std::numeric_limits<double>::quiet_NaN();
  try {
    camera_from_json(j, "depth.exr", "header");
    ADD_FAILURE() << "accepted a NaN translation";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "depth.exr: header camera \"cam0\".cam_from_world: \"translation\" holds a value that is not a "
              "finite number");
  }
}

TEST(CamerasFile, NearlyUnitQuaternionIsNormalised) {
  std::mt19937_64 rng(25);
  json j = camera_to_json(random_set(rng).cameras[0]);
  j["cam_from_world"]["rotation_xyzw"] = {0, 0, 0, 1.0005};
  const Camera c = camera_from_json(j, "f.json", "");
  EXPECT_NEAR(c.cam_from_world.rotation.norm(), 1.0, 1e-15);
  EXPECT_EQ(c.cam_from_world.rotation.w(), 1.0);
}

}  // namespace
}  // namespace pg
