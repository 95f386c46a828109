#include "pg/eval/truth_import.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "pg/core/error.h"
#include "pg/core/log.h"
#include "pg/image/image_io.h"

namespace pg {

namespace {

Rigid3 rigid_from_rotation(const Eigen::Matrix3d& R_cam_from_world, const Eigen::Vector3d& t,
                           const std::filesystem::path& path, const std::string& id) {
  const double det = R_cam_from_world.determinant();
  if (!(std::abs(det - 1) < 1e-3) || !R_cam_from_world.isUnitary(1e-3))
    throw InputError(path, str("camera ", id, ": R is not a rotation (det ", det, ")"));
  // Re-orthonormalise the printed matrix.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R_cam_from_world, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Rigid3 r;
  r.rotation = Eigen::Quaterniond(svd.matrixU() * svd.matrixV().transpose()).normalized();
  r.translation = t;
  return r;
}

std::vector<double> read_numbers(std::istream& in, std::size_t count, const std::filesystem::path& path,
                                 const std::string& what) {
  std::vector<double> v(count);
  for (double& x : v)
    if (!(in >> x) || !std::isfinite(x))
      throw InputError(path, str("expected ", count, " numbers for ", what));
  return v;
}

}  // namespace

CameraSet import_middlebury_par(const std::filesystem::path& par_file,
                                const std::function<int(const std::string& name)>& image_quarter_turns) {
  std::ifstream in(par_file);
  if (!in) throw InputError(par_file, "cannot open");
  long long count = 0;
  if (!(in >> count) || count < 1 || count > 100000)
    throw InputError(par_file, "expected an image count in [1, 100000]");
  CameraSet set;
  for (long long i = 0; i < count; ++i) {
    std::string name;
    if (!(in >> name)) throw InputError(par_file, str("expected ", count, " cameras, found ", i));
    const std::vector<double> v = read_numbers(in, 21, par_file, name);
    Camera c;
    c.id = std::filesystem::path(name).stem().string();
    c.image = name;
    Eigen::Matrix3d K, R;
    K << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
    R << v[9], v[10], v[11], v[12], v[13], v[14], v[15], v[16], v[17];
    if (!(K(0, 0) > 0) || !(K(1, 1) > 0))
      throw InputError(par_file, str("camera ", name, ": focal length not positive"));
    c.intrinsics = {K(0, 0), K(1, 1), K(0, 2), K(1, 2)};
    c.cam_from_world = rigid_from_rotation(R, Eigen::Vector3d(v[18], v[19], v[20]), par_file, name);
    c.width = 640;
    c.height = 480;
    const std::filesystem::path image = par_file.parent_path() / name;
    if (std::filesystem::exists(image))
      if (const auto size = peek_image_size(image)) c.width = size->width, c.height = size->height;
    const int turns = image_quarter_turns ? image_quarter_turns(name) : 0;
    if (turns % 2 != 0) std::swap(c.width, c.height);  // the size the file's frame has
    set.cameras.push_back(turned_camera(c, turns));
  }
  return set;
}

int temple_ring_quarter_turns(const std::string& image_name) {
  int number = 0;
  if (std::sscanf(image_name.c_str(), "templeR%4d.png", &number) != 1 || number < 1 || number > 47) return 0;
  return number <= 31 ? 1 : -1;
}

CameraSet import_strecha_cameras(const std::filesystem::path& folder,
                                 const std::filesystem::path& image_folder, double image_scale) {
  if (!std::filesystem::is_directory(folder)) throw InputError(folder, "not a folder");
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().extension() == ".camera") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  if (files.empty()) throw InputError(folder, "no .camera files");
  CameraSet set;
  for (const auto& path : files) {
    std::ifstream in(path);
    if (!in) throw InputError(path, "cannot open");
    const std::string image_name = path.stem().string();  // "0000.jpg"
    const std::vector<double> v = read_numbers(in, 9 + 3 + 9 + 3 + 2, path, "K, distortion, R, C, size");
    Camera c;
    c.id = std::filesystem::path(image_name).stem().string();
    c.image = image_folder.empty() ? image_name : (image_folder / image_name).string();
    c.intrinsics = {v[0], v[4], v[2], v[5]};
    if (!(v[0] > 0) || !(v[4] > 0)) throw InputError(path, "focal length not positive");
    c.distortion.k1 = v[9];
    c.distortion.k2 = v[10];
    Eigen::Matrix3d R_world_from_cam;
    R_world_from_cam << v[12], v[13], v[14], v[15], v[16], v[17], v[18], v[19], v[20];
    const Eigen::Vector3d C(v[21], v[22], v[23]);
    const Eigen::Matrix3d R = R_world_from_cam.transpose();
    c.cam_from_world = rigid_from_rotation(R, -R * C, path, c.id);
    if (!(v[24] >= 1 && v[24] <= 65536 && v[25] >= 1 && v[25] <= 65536))
      throw InputError(path, "image size out of range");
    c.width = static_cast<int>(v[24]);
    c.height = static_cast<int>(v[25]);
    set.cameras.push_back(image_scale == 1.0 ? c : resized_camera(c, image_scale));
  }
  return set;
}

}  // namespace pg
