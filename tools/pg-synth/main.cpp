// pg-synth: renders a built-in scene with exact ground truth into the documented formats.
#include "common/cli.h"
#include "pg/core/error.h"
#include "pg/synth/scenes.h"
#include "pg/synth/write_scene.h"

int main(int argc, char** argv) {
  pg::cli::Frame frame(
      {"pg-synth", "Render a built-in synthetic scene: images, exact depth EXRs, cameras JSON, mesh.",
       "  pg-synth set --out shot/synth                 # 16-view orbit of a textured set\n"
       "  pg-synth checkerboard --lens fisheye --out b  # 15 board views through a fisheye\n"
       "  pg-synth room --height 512 --out pano         # two panoramas 27 cm apart\n"
       "  pg-synth deform --out refine                  # truth + initial mesh for pg-refine"});
  std::string scene_name;
  std::string out;
  std::string lens = "pinhole";
  std::string encoding = "srgb8";
  pg::synth::SceneOptions scene_options;
  pg::synth::WriteOptions write_options;
  auto& app = frame.app();
  app.add_option("scene", scene_name, "set, checkerboard, room or deform")
      ->required()
      ->check(CLI::IsMember(pg::synth::scene_names()));
  app.add_option("--out", out, "output folder (created if missing)")->required();
  app.add_option("--width", scene_options.width, "image width of perspective scenes")
      ->capture_default_str()
      ->check(CLI::Range(16, 16384));
  app.add_option("--height", scene_options.height, "image height (panoramas are 2 x height wide)")
      ->capture_default_str()
      ->check(CLI::Range(16, 16384));
  app.add_option("--views", scene_options.views, "number of views (0 = the scene's default)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--lens", lens, "checkerboard lens: pinhole or fisheye")
      ->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "fisheye"}));
  app.add_option("--supersample", write_options.supersample, "samples per pixel side for anti-aliasing")
      ->capture_default_str()
      ->check(CLI::Range(1, 8));
  app.add_option(
         "--encoding", encoding,
         "images: srgb8 (8-bit sRGB, as a camera) or linear16 (16-bit linear light, for measurements)")
      ->capture_default_str()
      ->check(CLI::IsMember({"srgb8", "linear16"}));
  app.add_flag("!--no-depth", write_options.write_depth, "skip the depth EXRs");

  return frame.run(argc, argv, [&] {
    scene_options.seed = std::uint32_t(frame.seed());
    scene_options.lens = pg::camera_model_from_string(lens);
    write_options.encoding = pg::synth::image_encoding_from_string(encoding);
    frame.output_dir(out);
    pg::synth::Scene scene = pg::synth::make_scene(scene_name, scene_options);
    pg::synth::write_scene(scene, out, write_options);
  });
}
