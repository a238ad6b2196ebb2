#include "synth/scene_mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace dome::synth {

bool Solid::Inside(const Eigen::Vector3d& p) const {
  switch (type) {
    case Type::kNone:
      return false;
    case Type::kCapsule: {
      const double radial = std::hypot(p.x(), p.y());
      if (p.z() < 0.0) return p.norm() < radius0_mm * shrink - margin_mm;
      if (p.z() > length_mm) {
        return (p - Eigen::Vector3d(0, 0, length_mm)).norm() < radius1_mm * shrink - margin_mm;
      }
      const double r = radius0_mm + (radius1_mm - radius0_mm) * p.z() / length_mm;
      return radial < r * shrink - margin_mm;
    }
    case Type::kEllipsoid: {
      // Conservative: scale the point by the semi-axes, compare with a unit sphere
      // shrunk by the margin relative to the smallest semi-axis.
      const Eigen::Vector3d q = p.cwiseQuotient(half_extent_mm * shrink);
      const double limit = 1.0 - margin_mm / (half_extent_mm.minCoeff() * shrink);
      return q.norm() < limit;
    }
    case Type::kBox:
      return (p.cwiseAbs() - half_extent_mm).maxCoeff() < -margin_mm;
  }
  return false;
}

int SceneMesh::AddPart(const Part& part, const LocalMesh& local) {
  DOME_CHECK(parts.size() < 65535, "too many parts");
  const int index = static_cast<int>(parts.size());
  parts.push_back(part);
  const int base = static_cast<int>(vertices.size());
  for (size_t i = 0; i < local.vertices.size(); ++i) {
    vertices.push_back((part.rotation * local.vertices[i] + part.translation_mm).cast<float>());
    normals.push_back((part.rotation * local.normals[i]).normalized().cast<float>());
  }
  for (const auto& f : local.faces) {
    faces.push_back(f + Eigen::Vector3i::Constant(base));
    face_part.push_back(static_cast<uint16_t>(index));
  }
  return index;
}

void SceneMesh::Append(const SceneMesh& other) {
  const int vbase = static_cast<int>(vertices.size());
  const int pbase = static_cast<int>(parts.size());
  DOME_CHECK(parts.size() + other.parts.size() < 65535, "too many parts");
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  parts.insert(parts.end(), other.parts.begin(), other.parts.end());
  for (size_t i = 0; i < other.faces.size(); ++i) {
    faces.push_back(other.faces[i] + Eigen::Vector3i::Constant(vbase));
    face_part.push_back(static_cast<uint16_t>(other.face_part[i] + pbase));
  }
}

int SceneMesh::RemoveBuriedFaces() {
  std::vector<int> solids;
  for (size_t p = 0; p < parts.size(); ++p) {
    if (parts[p].solid.type != Solid::Type::kNone) solids.push_back(static_cast<int>(p));
  }
  if (solids.empty()) return 0;
  // Bounding spheres of the solids for a cheap rejection.
  std::vector<double> radius(parts.size(), 0.0);
  for (int p : solids) {
    const Solid& s = parts[p].solid;
    switch (s.type) {
      case Solid::Type::kCapsule:
        radius[p] = s.length_mm + std::max(s.radius0_mm, s.radius1_mm);
        break;
      default:
        radius[p] = s.half_extent_mm.norm();
        break;
    }
  }
  std::vector<char> keep(faces.size(), 1);
  int removed = 0;
  for (size_t f = 0; f < faces.size(); ++f) {
    const int own = face_part[f];
    for (int p : solids) {
      if (p == own) continue;
      const Part& part = parts[p];
      bool all_inside = true;
      for (int k = 0; k < 3 && all_inside; ++k) {
        const Eigen::Vector3d w = vertices[faces[f][k]].cast<double>();
        if ((w - part.translation_mm).squaredNorm() > radius[p] * radius[p]) {
          all_inside = false;
        } else {
          all_inside = part.solid.Inside(part.ToLocal(w));
        }
      }
      if (all_inside) {
        keep[f] = 0;
        ++removed;
        break;
      }
    }
  }
  if (removed == 0) return 0;
  std::vector<int> remap(vertices.size(), -1);
  std::vector<Eigen::Vector3f> new_vertices, new_normals;
  std::vector<Eigen::Vector3i> new_faces;
  std::vector<uint16_t> new_face_part;
  for (size_t f = 0; f < faces.size(); ++f) {
    if (!keep[f]) continue;
    Eigen::Vector3i nf;
    for (int k = 0; k < 3; ++k) {
      int& m = remap[faces[f][k]];
      if (m < 0) {
        m = static_cast<int>(new_vertices.size());
        new_vertices.push_back(vertices[faces[f][k]]);
        new_normals.push_back(normals[faces[f][k]]);
      }
      nf[k] = m;
    }
    new_faces.push_back(nf);
    new_face_part.push_back(face_part[f]);
  }
  vertices = std::move(new_vertices);
  normals = std::move(new_normals);
  faces = std::move(new_faces);
  face_part = std::move(new_face_part);
  return removed;
}

LocalMesh LatheMesh(const std::vector<ProfilePoint>& profile, int segments) {
  DOME_CHECK(profile.size() >= 2 && segments >= 3, "degenerate lathe");
  LocalMesh mesh;
  // Ring k starts at ring_start[k]; a pole (r == 0) is a single vertex.
  std::vector<int> ring_start;
  std::vector<bool> pole;
  for (const auto& pp : profile) {
    ring_start.push_back(static_cast<int>(mesh.vertices.size()));
    if (pp.r_mm <= 0.0) {
      pole.push_back(true);
      mesh.vertices.emplace_back(0.0, 0.0, pp.z_mm);
      mesh.normals.emplace_back(0.0, 0.0, pp.n_z > 0 ? 1.0 : -1.0);
      continue;
    }
    pole.push_back(false);
    for (int j = 0; j < segments; ++j) {
      const double a = 2.0 * M_PI * j / segments;
      const double c = std::cos(a), s = std::sin(a);
      mesh.vertices.emplace_back(pp.r_mm * c, pp.r_mm * s, pp.z_mm);
      mesh.normals.push_back(Eigen::Vector3d(pp.n_r * c, pp.n_r * s, pp.n_z).normalized());
    }
  }
  for (size_t k = 0; k + 1 < profile.size(); ++k) {
    const int lo = ring_start[k], hi = ring_start[k + 1];
    for (int j = 0; j < segments; ++j) {
      const int j1 = (j + 1) % segments;
      if (pole[k] && pole[k + 1]) continue;
      if (pole[k]) {
        mesh.faces.emplace_back(lo, hi + j1, hi + j);
      } else if (pole[k + 1]) {
        mesh.faces.emplace_back(lo + j, lo + j1, hi);
      } else {
        mesh.faces.emplace_back(lo + j, lo + j1, hi + j1);
        mesh.faces.emplace_back(lo + j, hi + j1, hi + j);
      }
    }
  }
  return mesh;
}

LocalMesh CapsuleMesh(double length_mm, double radius0_mm, double radius1_mm, int segments,
                      int cap_rings) {
  std::vector<ProfilePoint> profile;
  for (int i = 0; i <= cap_rings; ++i) {  // bottom cap: latitude -90 .. 0 degrees
    const double phi = -0.5 * M_PI + 0.5 * M_PI * i / cap_rings;
    profile.push_back(
        {radius0_mm * std::sin(phi), radius0_mm * std::cos(phi), std::sin(phi), std::cos(phi)});
  }
  for (int i = 0; i <= cap_rings; ++i) {  // top cap: latitude 0 .. 90 degrees
    const double phi = 0.5 * M_PI * i / cap_rings;
    profile.push_back({length_mm + radius1_mm * std::sin(phi), radius1_mm * std::cos(phi),
                       std::sin(phi), std::cos(phi)});
  }
  for (auto& p : profile) {
    if (std::abs(p.r_mm) < 1e-9) p.r_mm = 0.0;
  }
  return LatheMesh(profile, segments);
}

namespace {
// Factor by which a lat-long tessellation with these steps stays outside the shrunk
// analytic surface (its faces' distance from the centre, conservatively).
double TessellationShrink(int segments, int rings_per_half_pi) {
  const double half_lon = M_PI / segments;
  const double half_lat = 0.25 * M_PI / rings_per_half_pi;
  return std::cos(std::sqrt(half_lon * half_lon + half_lat * half_lat)) * 0.995;
}
}  // namespace

Solid CapsuleSolid(double length_mm, double radius0_mm, double radius1_mm, int segments,
                   int cap_rings) {
  Solid s;
  s.type = Solid::Type::kCapsule;
  s.length_mm = length_mm;
  s.radius0_mm = radius0_mm;
  s.radius1_mm = radius1_mm;
  s.shrink = TessellationShrink(segments, cap_rings);
  return s;
}

LocalMesh EllipsoidMesh(const Eigen::Vector3d& semi_axes_mm, int segments, int rings) {
  std::vector<ProfilePoint> profile;
  for (int i = 0; i <= rings; ++i) {
    const double phi = -0.5 * M_PI + M_PI * i / rings;
    double r = std::cos(phi);
    if (i == 0 || i == rings) r = 0.0;
    profile.push_back({std::sin(phi), r, std::sin(phi), r});
  }
  LocalMesh mesh = LatheMesh(profile, segments);
  const Eigen::Vector3d inv = semi_axes_mm.cwiseInverse();
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    mesh.vertices[i] = mesh.vertices[i].cwiseProduct(semi_axes_mm);
    // Normals transform by the inverse transpose of the scaling.
    mesh.normals[i] = mesh.normals[i].cwiseProduct(inv).normalized();
  }
  return mesh;
}

Solid EllipsoidSolid(const Eigen::Vector3d& semi_axes_mm, int segments, int rings) {
  Solid s;
  s.type = Solid::Type::kEllipsoid;
  s.half_extent_mm = semi_axes_mm;
  s.shrink = TessellationShrink(segments, std::max(1, rings / 2));
  return s;
}

LocalMesh BoxMesh(const Eigen::Vector3d& size_mm) {
  LocalMesh mesh;
  const Eigen::Vector3d h = 0.5 * size_mm;
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[axis] = sign;
      // Two in-face axes u, v with u x v = n.
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      Eigen::Vector3d u = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
      u[a] = 1.0;
      v[b] = sign;
      const Eigen::Vector3d c = n.cwiseProduct(h);
      const Eigen::Vector3d du = u * h[a], dv = v * h[b];
      const int base = static_cast<int>(mesh.vertices.size());
      const Eigen::Vector3d corners[4] = {c - du - dv, c + du - dv, c + du + dv, c - du + dv};
      for (const auto& corner : corners) {
        mesh.vertices.push_back(corner);
        mesh.normals.push_back(n);
      }
      mesh.faces.emplace_back(base, base + 1, base + 2);
      mesh.faces.emplace_back(base, base + 2, base + 3);
    }
  }
  return mesh;
}

Solid BoxSolid(const Eigen::Vector3d& size_mm) {
  Solid s;
  s.type = Solid::Type::kBox;
  s.half_extent_mm = 0.5 * size_mm;
  return s;
}

LocalMesh GridMesh(const Eigen::Vector3d& origin_mm, const Eigen::Vector3d& u_axis, double u_len_mm,
                   int nu, const Eigen::Vector3d& v_axis, double v_len_mm, int nv) {
  LocalMesh mesh;
  const Eigen::Vector3d n = u_axis.cross(v_axis).normalized();
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      mesh.vertices.push_back(origin_mm + u_axis * (u_len_mm * i / nu) +
                              v_axis * (v_len_mm * j / nv));
      mesh.normals.push_back(n);
    }
  }
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const int a = j * (nu + 1) + i;
      mesh.faces.emplace_back(a, a + 1, a + nu + 2);
      mesh.faces.emplace_back(a, a + nu + 2, a + nu + 1);
    }
  }
  return mesh;
}

}  // namespace dome::synth
