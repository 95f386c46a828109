#include "stage_runs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "pg/testing/testing.h"

namespace fs = std::filesystem;
using pg::testing::run_tool;

namespace pg::reliability {
namespace {

std::string s(const fs::path& p) {
  return p.string();
}

void synth(const fs::path& out, std::vector<std::string> args) {
  args.insert(args.end(), {"--out", s(out), "--supersample", "1", "--progress", "off"});
  const auto r = run_tool("pg-synth", args);
  if (r.exit_code != 0) throw std::runtime_error("pg-synth " + args[0] + " failed: " + r.stderr_text);
}

std::vector<std::string> board_args() {
  std::ifstream file(scene("board") / "scene.json");
  const nlohmann::json scene = nlohmann::json::parse(file);
  const auto& corners = scene["extras"]["inner_corners"];
  const std::string board =
      std::to_string(corners[0].get<int>()) + "x" + std::to_string(corners[1].get<int>());
  return {"--board", board, "--square", std::to_string(scene["extras"]["square_size"].get<double>())};
}

}  // namespace

const fs::path& shared_inputs() {
  static const pg::testing::TempDir dir;
  return dir.path();
}

fs::path scene(const std::string& name) {
  // Made on first use: each test process (ctest runs every test alone) renders only what it reads.
  static const std::map<std::string, std::vector<std::string>> recipes = {
      {"set", {"set", "--width", "160", "--height", "120", "--views", "3"}},
      // Sixteen orbit views 22.5 degrees apart: neighbours overlap enough to refine.
      {"deform", {"deform", "--no-depth", "--width", "160", "--height", "120"}},
      // pg-track needs more texture and pixels than the deform rock at 160 x 120 gives.
      {"orbit", {"set", "--no-depth", "--width", "320", "--height", "240"}},
      {"room", {"room", "--height", "48", "--no-depth"}},
      {"board", {"checkerboard", "--width", "320", "--height", "240", "--views", "8", "--no-depth"}},
  };
  const fs::path dir = shared_inputs() / name;
  if (!fs::exists(dir / "cameras.json")) synth(dir, recipes.at(name));
  return dir;
}

const std::vector<StageRun>& stage_runs() {
  static const std::vector<StageRun> runs = {
      {"synth", "pg-synth",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         return {"set", "--width",       "160", "--height", "120", "--views",
                 "3",   "--supersample", "1",   "--out",    s(out)};
       }},
      {"calib", "pg-calib",
       [](const fs::path&, const fs::path& out) {
         std::vector<std::string> a = {"calibrate", "--images", s(scene("board") / "images")};
         const auto board = board_args();
         a.insert(a.end(), board.begin(), board.end());
         a.insert(a.end(), {"--out", s(out / "calib.json")});
         return a;
       }},
      {"track", "pg-track",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         // Three neighbouring orbit views, all of which register.
         return {"--images",  s(scene("orbit") / "images"),
                 "--cameras", s(scene("orbit") / "cameras.json"),
                 "--range",   "3:3",
                 "--out",     s(out)};
       }},
      {"depth", "pg-depth",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         return {"--cameras", s(scene("set") / "cameras.json"), "--out-dir", s(out), "--ply", "--mesh",
                 "--preview"};
       }},
      {"merge", "pg-merge",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         const fs::path d = scene("set") / "depth";
         return {"volume",
                 "--depth",
                 s(d / "view_000.exr"),
                 s(d / "view_001.exr"),
                 s(d / "view_002.exr"),
                 "--voxel-size",
                 "0.05",
                 "--out",
                 s(out / "merged.ply"),
                 "--vdb",
                 s(out / "merged.vdb")};
       }},
      {"points", "pg-merge",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         // The scene's mesh read as a point cloud (its vertices): normals, orientation, Poisson.
         return {"points", "--points", s(scene("set") / "mesh.ply"), "--voxel-size",
                 "0.05",   "--out",    s(out / "surface.ply")};
       }},
      {"refine", "pg-refine",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         const fs::path d = scene("deform");
         return {"--mesh",       s(d / "initial.ply"),
                 "--cameras",    s(d / "cameras.json"),
                 "--out",        s(out / "refined.ply"),
                 "--pre-cache",  s(out / "pre.ply"),
                 "--post-cache", s(out / "post.ply"),
                 "--views",      "view_000,view_001,view_002",
                 "--pairs",      "view_000:view_001,view_001:view_002",
                 "--iterations", "2",
                 "--scale",      "1"};
       }},
      {"remesh", "pg-remesh",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         return {"--in",
                 s(scene("deform") / "initial.ply"),
                 "--out",
                 s(out / "remeshed.ply"),
                 "--iterations",
                 "3",
                 "--quality-report",
                 s(out / "remesh.json")};
       }},
      {"sphdepth", "pg-sphdepth",
       [](const fs::path&, const fs::path& out) -> std::vector<std::string> {
         return {"--cameras", s(scene("room") / "cameras.json"), "--out-dir", s(out)};
       }},
  };
  return runs;
}

int run_stage(const StageRun& stage, const fs::path& out, const std::vector<std::string>& extra,
              std::string* stderr_text) {
  fs::create_directories(out);
  std::vector<std::string> args = stage.args(shared_inputs(), out);
  args.insert(args.end(), {"--progress", "off", "--log-level", "warn"});
  args.insert(args.end(), extra.begin(), extra.end());
  const auto r = run_tool(stage.tool, args);
  if (stderr_text) *stderr_text = r.stderr_text;
  return r.exit_code;
}

int run_stage_as(const StageRun& stage, const fs::path& dir, const std::string& name,
                 const std::vector<std::string>& extra, std::string* stderr_text) {
  fs::remove_all(dir / "run");
  const int code = run_stage(stage, dir / "run", extra, stderr_text);
  fs::remove_all(dir / name);
  fs::rename(dir / "run", dir / name);
  return code;
}

std::vector<fs::path> final_outputs(const fs::path& out) {
  std::vector<fs::path> files;
  if (!fs::exists(out)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(out))
    if (entry.is_regular_file() && entry.path().filename().string().find(".pg-tmp-") == std::string::npos)
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::map<std::string, std::string> output_digests(const fs::path& out) {
  std::map<std::string, std::string> digests;
  for (const fs::path& file : final_outputs(out)) {
    const auto r = run_tool("pg-info", {"digest", s(file)});
    std::istringstream line(r.stdout_text);
    std::string digest;
    line >> digest;
    digests[fs::relative(file, out).string()] = r.exit_code == 0 ? digest : "digest failed: " + r.stderr_text;
  }
  return digests;
}

bool validatable(const fs::path& file) {
  static const std::vector<std::string> known = {".json", ".ply", ".obj", ".exr", ".vdb",
                                                 ".flo",  ".png", ".jpg", ".tif", ".hdr"};
  return std::find(known.begin(), known.end(), file.extension().string()) != known.end();
}

}  // namespace pg::reliability
