#include "io/mesh.h"

namespace dome::io {

std::string Mesh::Inconsistency() const {
  const size_t n = vertices.size();
  auto attribute = [n](size_t size, const char* name) -> std::string {
    if (size == 0 || size == n) {
      return "";
    }
    return std::string(name) + " has " + std::to_string(size) + " entries for " +
           std::to_string(n) + " vertices";
  };
  for (const std::string& s :
       {attribute(normals.size(), "normals"), attribute(colors.size(), "colors"),
        attribute(alphas.size(), "alphas")}) {
    if (!s.empty()) {
      return s;
    }
  }
  if (!alphas.empty() && colors.empty()) {
    return "alphas without colors";
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int i = faces[f][k];
      if (i < 0 || static_cast<size_t>(i) >= n) {
        return "face " + std::to_string(f) + " refers to vertex " + std::to_string(i) + " of " +
               std::to_string(n);
      }
    }
  }
  return "";
}

}  // namespace dome::io
