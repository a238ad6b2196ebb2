// The synthetic scene as one triangle mesh: what is ray-cast, and what is written
// as the ground truth (TAKE/truth/<instant>/mesh.ply), so the two agree exactly.
//
// Frames and units: world frame, millimetres, z up, the floor at z = 0, the dome's
// centre on the vertical axis x = y = 0. Each Part is a rigid piece (a limb, the
// bat, the floor) with its own local frame: local = R^T (world - t). Textures are
// defined in the local frame, so they move with the body (synth/texture.h).
// Triangles are counter-clockwise seen from outside: outward normal = (b-a) x (c-a).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "synth/texture.h"

namespace dome::synth {

// A primitive tessellated in its own local frame (mm), with unit shading normals.
struct LocalMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3d> normals;
  std::vector<Eigen::Vector3i> faces;
};

// A convex solid in a part's local frame, for removing triangles that are buried in
// another part (hidden from every outside viewpoint). Inside() uses the analytic
// shape shrunk by `shrink` (a factor) and `margin_mm`, so that "inside the solid"
// implies "inside its tessellation".
struct Solid {
  enum class Type { kNone, kCapsule, kEllipsoid, kBox };
  Type type = Type::kNone;
  double length_mm = 0.0;   // capsule: axis from local z = 0 to z = length
  double radius0_mm = 0.0;  // capsule radius at z = 0
  double radius1_mm = 0.0;  // capsule radius at z = length
  Eigen::Vector3d half_extent_mm = Eigen::Vector3d::Zero();  // ellipsoid semi-axes / box half sizes
  double shrink = 1.0;                                       // multiplies radii / semi-axes
  double margin_mm = 0.5;                                    // subtracted after shrinking

  bool Inside(const Eigen::Vector3d& local_mm) const;
};

struct Part {
  std::string name;
  Material material = Material::kFloor;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();    // local -> world
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();  // local -> world
  bool on_person = false;  // true for the person and the bat (what moves)
  Solid solid;

  Eigen::Vector3d ToLocal(const Eigen::Vector3d& world_mm) const {
    return rotation.transpose() * (world_mm - translation_mm);
  }
};

struct SceneMesh {
  std::vector<Eigen::Vector3f> vertices;  // world, mm
  std::vector<Eigen::Vector3f> normals;   // world, unit, per vertex (smooth shading)
  std::vector<Eigen::Vector3i> faces;
  std::vector<uint16_t> face_part;  // index into parts, one per face
  std::vector<Part> parts;

  // Adds `local` placed by part.rotation / part.translation_mm; returns the part index.
  int AddPart(const Part& part, const LocalMesh& local);
  // Appends another mesh (parts renumbered).
  void Append(const SceneMesh& other);
  // Removes every face whose three vertices lie inside another part's solid (such a
  // face is enclosed by that part's closed convex surface, so no ray from outside
  // can reach it), then drops unused vertices. Returns the number of faces removed.
  int RemoveBuriedFaces();
};

// Surface of revolution about local z. `profile` lists (z, r) from bottom to top with
// the outward normal (n_z, n_r) of the profile at each point; r = 0 makes a pole.
struct ProfilePoint {
  double z_mm, r_mm, n_z, n_r;
};
LocalMesh LatheMesh(const std::vector<ProfilePoint>& profile, int segments);

// Capsule along local z from 0 to length_mm: a cone frustum of radii r0 (z = 0) and
// r1 (z = length) closed by hemispheres of those radii.
LocalMesh CapsuleMesh(double length_mm, double radius0_mm, double radius1_mm, int segments,
                      int cap_rings);
Solid CapsuleSolid(double length_mm, double radius0_mm, double radius1_mm, int segments,
                   int cap_rings);

// Ellipsoid centred at the origin with the given semi-axes (x, y, z).
LocalMesh EllipsoidMesh(const Eigen::Vector3d& semi_axes_mm, int segments, int rings);
Solid EllipsoidSolid(const Eigen::Vector3d& semi_axes_mm, int segments, int rings);

// Axis-aligned box centred at the origin (flat-shaded).
LocalMesh BoxMesh(const Eigen::Vector3d& size_mm);
Solid BoxSolid(const Eigen::Vector3d& size_mm);

// Flat rectangle origin + a u_axis + b v_axis, a in [0, u_len], b in [0, v_len],
// cut into nu x nv cells; it faces u_axis x v_axis.
LocalMesh GridMesh(const Eigen::Vector3d& origin_mm, const Eigen::Vector3d& u_axis, double u_len_mm,
                   int nu, const Eigen::Vector3d& v_axis, double v_len_mm, int nv);

}  // namespace dome::synth
