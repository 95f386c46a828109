// pg-info: facts about the installation and about files.
#include <iostream>

#include "common/cli.h"
#include "digest.h"
#include "pg/core/error.h"
#include "pg/gpu/device.h"
#include "validate.h"

namespace {

void print_devices() {
  const auto list = pg::gpu::list_devices();
  for (const auto& d : list)
    std::cout << pg::gpu::to_string(d.kind) << ":" << d.index << "  " << d.name << "  [" << d.platform << ", "
              << d.driver << "]  " << (d.is_gpu ? "gpu" : "cpu") << ", " << d.compute_units << " units, "
              << (d.global_memory >> 20) << " MiB" << (d.double_precision ? ", fp64" : "") << "\n";
  for (const auto& [kind, reason] : {std::pair{"opencl", pg::gpu::opencl_unavailable_reason()},
                                     std::pair{"cuda", pg::gpu::cuda_unavailable_reason()}})
    if (!reason.empty()) std::cout << kind << ": none (" << reason << ")\n";
  std::cout << "--device " << pg::gpu::to_string(pg::gpu::requested_device()) << " runs on "
            << pg::gpu::describe_active_device() << "\n";
}

}  // namespace

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
      "digest",
      "print a SHA-256 of each file's content without its provenance: equal digests, equal results");
  digest->add_option("files", files, "files to digest")->required();

  auto* devices = app.add_subcommand(
      "devices", "list the OpenCL and CUDA devices accelerated stages can use, and what --device auto picks");

  return frame.run(argc, argv, [&] {
    if (devices->parsed()) return print_devices();
    for (const auto& f : files) frame.input(f);
    for (const auto& f : files) {
      if (validate->parsed()) std::cout << f << ": " << pg::info::validate_file(f) << "\n";
      if (digest->parsed()) std::cout << pg::info::content_digest(f) << "  " << f << "\n";
    }
  });
}
