// pg-info: facts about the installation and about files.
#include <iostream>

#include "common/cli.h"
#include "pg/core/error.h"
#include "digest.h"
#include "validate.h"

int main(int argc, char** argv) {
  pg::cli::Frame frame({"pg-info", "Check pg files and report facts about this installation.",
                        "  pg-info validate shot/cameras.json shot/depth/*.exr shot/mesh.ply\n"
                        "  pg-info digest run1/mesh.ply run2/mesh.ply   # same digest: same result"});
  auto& app = frame.app();
  app.require_subcommand(1);
  std::vector<std::string> files;
  auto* validate = app.add_subcommand(
      "validate", "read each file with its format's reader; exit 3 on the first invalid one");
  validate->add_option("files", files, "files to check")->required();
  auto* digest = app.add_subcommand(
      "digest", "print a SHA-256 of each file's content without its provenance: equal digests, equal results");
  digest->add_option("files", files, "files to digest")->required();

  return frame.run(argc, argv, [&] {
    for (const auto& f : files) frame.input(f);
    for (const auto& f : files) {
      if (validate->parsed()) std::cout << f << ": " << pg::info::validate_file(f) << "\n";
      if (digest->parsed()) std::cout << pg::info::content_digest(f) << "  " << f << "\n";
    }
  });
}
