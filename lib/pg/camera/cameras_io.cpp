#include "pg/camera/cameras_io.h"

#include <map>
#include <set>

#include "pg/camera/camera_json.h"
#include "pg/core/atomic_file.h"
#include "pg/core/error.h"
#include "pg/core/json_file.h"

namespace pg {
namespace {

const nlohmann::json& required_array(const nlohmann::json& doc, const char* key,
                                     const std::filesystem::path& path) {
  auto it = doc.find(key);
  if (it == doc.end()) throw InputError(path, std::string("missing \"") + key + "\"");
  if (!it->is_array()) throw InputError(path, std::string("\"") + key + "\" is not an array");
  return *it;
}

Rig rig_from_json(const nlohmann::json& j, const std::filesystem::path& path, std::size_t index) {
  const JsonReader unnamed(j, path, "rigs[" + std::to_string(index) + "]");
  Rig rig;
  rig.id = unnamed.string("id");
  if (rig.id.empty()) unnamed.fail("\"id\" is empty");
  const JsonReader reader(j, path, "rig \"" + rig.id + "\"");
  for (const auto& [key, value] : j.items())
    if (key != "id" && key != "cameras" && key != "offset") reader.fail("unknown field \"" + key + "\"");
  const auto& cameras = j.find("cameras");
  if (cameras == j.end() || !cameras->is_array()) reader.fail("missing array \"cameras\"");
  for (const auto& id : *cameras) {
    if (!id.is_string()) reader.fail("\"cameras\" holds a value that is not a camera id");
    rig.camera_ids.push_back(id.get<std::string>());
  }
  if (j.contains("offset")) {
    const std::vector<double> offset = reader.numbers("offset", 3);
    rig.offset = Eigen::Vector3d(offset[0], offset[1], offset[2]);
  }
  return rig;
}

void check_rigs(const CameraSet& set, const std::filesystem::path& path) {
  std::map<std::string, std::string> rig_of_camera;
  std::set<std::string> rig_ids;
  for (const Rig& rig : set.rigs) {
    const std::string where = "rig \"" + rig.id + "\": ";
    if (!rig_ids.insert(rig.id).second) throw InputError(path, "duplicate rig id \"" + rig.id + "\"");
    if (rig.camera_ids.empty()) throw InputError(path, where + "lists no cameras");
    if (rig.offset && rig.camera_ids.size() != 2)
      throw InputError(path, where + "\"offset\" needs exactly two cameras, the rig has " +
                                 std::to_string(rig.camera_ids.size()));
    for (const std::string& id : rig.camera_ids) {
      const Camera* camera = set.find(id);
      if (!camera) throw InputError(path, where + "names unknown camera \"" + id + "\"");
      if (!rig_of_camera.emplace(id, rig.id).second)
        throw InputError(path,
                         where + "camera \"" + id + "\" is already in rig \"" + rig_of_camera[id] + "\"");
      if (camera->rig && *camera->rig != rig.id)
        throw InputError(path,
                         where + "camera \"" + id + "\" says it belongs to rig \"" + *camera->rig + "\"");
    }
  }
  for (const Camera& camera : set.cameras)
    if (camera.rig && !rig_of_camera.count(camera.id))
      throw InputError(path, "camera \"" + camera.id + "\": rig \"" + *camera.rig + "\" does not list it" +
                                 (rig_ids.count(*camera.rig) ? "" : " (no such rig)"));
}

}  // namespace

const Camera* CameraSet::find(const std::string& id) const {
  for (const Camera& camera : cameras)
    if (camera.id == id) return &camera;
  return nullptr;
}

CameraSet cameras_from_json(const nlohmann::json& doc, const std::filesystem::path& path) {
  check_format_header(doc, path, cameras_format_name, cameras_format_version);
  for (const auto& [key, value] : doc.items())
    if (key != "format" && key != "version" && key != "provenance" && key != "cameras" && key != "rigs")
      throw InputError(path, "unknown top-level field \"" + key + "\"");
  auto provenance = doc.find("provenance");
  if (provenance == doc.end() || !provenance->is_object())
    throw InputError(path, "missing \"provenance\" object");

  CameraSet set;
  set.provenance = provenance_from_json(*provenance);
  const nlohmann::json& cameras = required_array(doc, "cameras", path);
  set.cameras.reserve(cameras.size());
  std::set<std::string> ids;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    set.cameras.push_back(camera_from_json(cameras[i], path, "cameras[" + std::to_string(i) + "]"));
    if (!ids.insert(set.cameras.back().id).second)
      throw InputError(path, "duplicate camera id \"" + set.cameras.back().id + "\"");
  }
  if (doc.contains("rigs")) {
    const nlohmann::json& rigs = required_array(doc, "rigs", path);
    for (std::size_t i = 0; i < rigs.size(); ++i) set.rigs.push_back(rig_from_json(rigs[i], path, i));
  }
  check_rigs(set, path);
  return set;
}

CameraSet read_cameras(const std::filesystem::path& path) {
  nlohmann::json doc;
  try {
    doc = read_json_file(path);
  } catch (const nlohmann::json::exception& e) {
    // read_json_file converts parse errors; a number overflow such as 1e999 arrives as out_of_range.
    throw InputError(path, std::string("not valid JSON: ") + e.what());
  }
  return cameras_from_json(doc, path);
}

nlohmann::ordered_json cameras_to_json(const CameraSet& set) {
  nlohmann::ordered_json doc;
  doc["format"] = cameras_format_name;
  doc["version"] = cameras_format_version;
  doc["provenance"] = to_json(set.provenance.created_utc.empty() ? Provenance::current() : set.provenance);
  doc["cameras"] = nlohmann::ordered_json::array();
  for (const Camera& camera : set.cameras) doc["cameras"].push_back(camera_to_ordered_json(camera));
  if (!set.rigs.empty()) {
    doc["rigs"] = nlohmann::ordered_json::array();
    for (const Rig& rig : set.rigs) {
      nlohmann::ordered_json r;
      r["id"] = rig.id;
      r["cameras"] = rig.camera_ids;
      if (rig.offset) r["offset"] = {rig.offset->x(), rig.offset->y(), rig.offset->z()};
      doc["rigs"].push_back(r);
    }
  }
  return doc;
}

void write_cameras(const std::filesystem::path& path, const CameraSet& set) {
  const std::string text = cameras_to_json(set).dump(2) + "\n";
  try {
    cameras_from_json(nlohmann::json::parse(text), path);
  } catch (const InputError& e) {
    // The message already starts with the path.
    throw OutputError(path, std::string("refusing to write a camera set that would not read back: ") +
                                (e.what() + path.string().size() + 2));
  }
  write_file_atomically(path, text);
}

}  // namespace pg
