#include "geometry/rig.h"

#include <cmath>
#include <set>

#include "core/error.h"

namespace dome::geometry {

using core::Require;

std::string RigCameraWhere(const std::string& where, size_t i, const std::string& id) {
  return where + ": cameras[" + std::to_string(i) + "] (id '" + id + "')";
}

int Rig::Find(const std::string& id) const {
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].model.id == id) return static_cast<int>(i);
  }
  return -1;
}

void CheckRig(const Rig& rig, const std::string& where) {
  Require(!rig.cameras.empty(), where + ": cameras", "expected at least one camera");
  Require(std::isfinite(rig.source_unit_mm) && rig.source_unit_mm > 0, where + ": source_unit_mm",
          "expected a positive number of millimetres per source unit");
  std::set<std::string> ids;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto& cam = rig.cameras[i];
    const std::string cw = RigCameraWhere(where, i, cam.model.id);
    Require(!cam.model.id.empty(), cw + ".id", "expected a non-empty camera id");
    Require(cam.model.id.find_first_of("/\\ \t\n") == std::string::npos && cam.model.id != "." &&
                cam.model.id != "..",
            cw + ".id", "a camera id names files: no slashes, spaces or dot-only names");
    Require(ids.insert(cam.model.id).second, cw + ".id",
            "duplicate camera id '" + cam.model.id + "'");
    cam.model.Check(cw);
  }
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto& cam = rig.cameras[i];
    for (const auto& n : cam.neighbours) {
      const std::string nw = RigCameraWhere(where, i, cam.model.id) + ".neighbours";
      Require(n != cam.model.id, nw, "a camera cannot be its own neighbour");
      Require(ids.count(n) == 1, nw, "unknown camera id '" + n + "'");
    }
  }
}

}  // namespace dome::geometry
