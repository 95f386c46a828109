// pg-info: facts about the installation and about files.
#include <iostream>

#include "common/cli.h"
#include "pg/core/error.h"
#include "validate.h"

int main(int argc, char** argv) {
  pg::cli::Frame frame({"pg-info", "Check pg files and report facts about this installation.",
                        "  pg-info validate shot/cameras.json shot/depth/*.exr shot/mesh.ply"});
  auto& app = frame.app();
  app.require_subcommand(1);
  std::vector<std::string> files;
  auto* validate = app.add_subcommand(
      "validate", "read each file with its format's reader; exit 3 on the first invalid one");
  validate->add_option("files", files, "files to check")->required();

  return frame.run(argc, argv, [&] {
    if (validate->parsed()) {
      for (const auto& f : files) {
        frame.input(f);
        std::cout << f << ": " << pg::info::validate_file(f) << "\n";
      }
    }
  });
}
