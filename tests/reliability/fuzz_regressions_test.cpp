// Every input a fuzzer once crashed a reader with (testdata/fuzz-regressions/<target>/) is now
// refused with InputError or read; nothing else may escape. The folder names match fuzz/fuzz_<target>.
#include <gtest/gtest.h>

#include <functional>
#include <map>

#include "pg/build_info.h"
#include "pg/camera/cameras_io.h"
#include "pg/core/error.h"
#include "pg/core/json_file.h"
#include "pg/core/provenance.h"
#include "pg/eval/flo_io.h"
#include "pg/fusion/depth_frame.h"
#include "pg/fusion/scan.h"
#include "pg/image/depth_exr.h"
#include "pg/image/exif.h"
#include "pg/image/image_io.h"
#include "pg/mesh/obj_io.h"
#include "pg/mesh/ply_io.h"
#include "pg/mesh/point_cloud.h"
#include "pg/mesh/vertex_mask.h"
#include "pg/refine/brush_strokes.h"
#include "pg/track/tracks.h"

namespace fs = std::filesystem;

namespace {

const std::map<std::string, std::function<void(const fs::path&)>>& readers() {
  static const std::map<std::string, std::function<void(const fs::path&)>> table = {
      {"cameras", [](const fs::path& p) { pg::read_cameras(p); }},
      {"depth_exr", [](const fs::path& p) { pg::read_depth_exr(p); }},
      {"exif", [](const fs::path& p) { pg::focal_px_from_exif(pg::read_exif_focal(p), 4000, 3000); }},
      {"image", [](const fs::path& p) { pg::read_image(p); }},
      {"ply_mesh", [](const fs::path& p) { pg::read_mesh_ply(p); }},
      {"point_cloud", [](const fs::path& p) { pg::read_point_cloud_ply(p); }},
      {"obj", [](const fs::path& p) { pg::read_mesh_obj(p); }},
      {"vertex_mask", [](const fs::path& p) { pg::read_vertex_mask(p); }},
      {"tracks", [](const fs::path& p) { pg::read_tracks(p); }},
      {"flo", [](const fs::path& p) { pg::read_flo(p); }},
      {"brush_strokes", [](const fs::path& p) { pg::read_brush_strokes(p); }},
      {"scan",
       [](const fs::path& p) {
         // Like the fuzz target: every scan reader must refuse the input cleanly, not just the first.
         for (const auto& read : {std::function<void()>([&] { pg::fusion::read_scan_mesh(p); }),
                                  std::function<void()>([&] { pg::fusion::read_scan_points(p); })}) {
           try {
             read();
           } catch (const pg::InputError& e) {
             EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
           }
         }
         pg::fusion::inspect_scan(p);
       }},
      {"scan_lists",
       [](const fs::path& p) {
         try {
           pg::fusion::read_stanford_conf(p);
         } catch (const pg::InputError&) {
         }
         pg::fusion::cameras_from_pose_list(p, {525, 525, 319.5, 239.5}, 640, 480);
       }},
      {"pg_json",
       [](const fs::path& p) {
         const nlohmann::json doc = pg::read_json_file(p);
         pg::check_format_header(doc, p, "pg-run-report", 1);
         const pg::JsonReader reader(doc, p, "report");
         if (reader.has("provenance")) pg::provenance_from_json(reader.child("provenance").node());
       }},
  };
  return table;
}

TEST(FuzzRegressions, EveryFoundInputIsRefusedCleanly) {
  const fs::path root = fs::path(pg::build_info::source_dir) / "testdata" / "fuzz-regressions";
  int checked = 0;
  for (const auto& [target, read] : readers()) {
    if (!fs::is_directory(root / target)) continue;
    for (const auto& entry : fs::directory_iterator(root / target)) {
      ++checked;
      try {
        read(entry.path());
      } catch (const pg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find(entry.path().string()), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << target << " reader threw a non-InputError on " << entry.path() << ": " << e.what();
      }
    }
  }
  for (const auto& entry : fs::directory_iterator(root))
    EXPECT_EQ(readers().count(entry.path().filename().string()), 1u) << "no reader for " << entry.path();
  EXPECT_GT(checked, 0);
}

}  // namespace
