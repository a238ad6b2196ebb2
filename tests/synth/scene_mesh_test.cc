#include "synth/scene_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>

#include "synth/noise.h"
#include "synth/scene.h"

namespace dome::synth {
namespace {

using Eigen::Vector3d;

// Every edge is shared by exactly two faces, traversed in opposite directions.
void ExpectClosedOriented(const LocalMesh& mesh) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second << " used twice";
    EXPECT_EQ(directed.count({edge.second, edge.first}), 1u) << "open edge";
  }
}

double SignedVolume(const LocalMesh& mesh) {
  double v = 0;
  for (const auto& f : mesh.faces) {
    v += mesh.vertices[f[0]].dot(mesh.vertices[f[1]].cross(mesh.vertices[f[2]])) / 6.0;
  }
  return v;
}

// Outward: the face normal points away from `centre`, and agrees with the vertex normals.
void ExpectOutward(const LocalMesh& mesh) {
  for (const auto& f : mesh.faces) {
    const Vector3d a = mesh.vertices[f[0]], b = mesh.vertices[f[1]], c = mesh.vertices[f[2]];
    const Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    const Vector3d vn = mesh.normals[f[0]] + mesh.normals[f[1]] + mesh.normals[f[2]];
    EXPECT_GT(n.normalized().dot(vn.normalized()), 0.5);
  }
  for (const auto& n : mesh.normals) EXPECT_NEAR(n.norm(), 1.0, 1e-9);
}

// True when p is inside the convex polytope (on the inner side of every face plane).
bool InsideConvex(const LocalMesh& mesh, const Vector3d& p) {
  for (const auto& f : mesh.faces) {
    const Vector3d a = mesh.vertices[f[0]];
    const Vector3d n = (mesh.vertices[f[1]] - a).cross(mesh.vertices[f[2]] - a);
    if (n.norm() < 1e-12) continue;
    if (n.dot(p - a) > 0) return false;
  }
  return true;
}

TEST(SceneMesh, CapsuleIsClosedOutwardWithTheRightVolume) {
  const LocalMesh m = CapsuleMesh(300, 50, 40, 20, 5);
  ExpectClosedOriented(m);
  ExpectOutward(m);
  const double frustum = M_PI * 300 / 3 * (50 * 50 + 50 * 40 + 40 * 40);
  const double caps = 2.0 / 3.0 * M_PI * (50 * 50 * 50 + 40 * 40 * 40);
  EXPECT_NEAR(SignedVolume(m) / (frustum + caps), 1.0, 0.05);
  EXPECT_LT(SignedVolume(m), frustum + caps);  // inscribed
}

TEST(SceneMesh, EllipsoidAndBoxAreClosedOutward) {
  const LocalMesh e = EllipsoidMesh(Vector3d(170, 110, 270), 28, 14);
  ExpectClosedOriented(e);
  ExpectOutward(e);
  EXPECT_NEAR(SignedVolume(e) / (4.0 / 3.0 * M_PI * 170 * 110 * 270), 1.0, 0.05);
  const LocalMesh b = BoxMesh(Vector3d(100, 250, 85));
  ExpectOutward(b);
  EXPECT_NEAR(SignedVolume(b), 100.0 * 250 * 85, 1e-6);
}

TEST(SceneMesh, SolidInsideImpliesInsideTheTessellation) {
  Rng rng(3);
  struct Case {
    LocalMesh mesh;
    Solid solid;
  };
  const Case cases[] = {
      {CapsuleMesh(300, 50, 42, 20, 5), CapsuleSolid(300, 50, 42, 20, 5)},
      {CapsuleMesh(780, 35, 35, 24, 5), CapsuleSolid(780, 35, 35, 24, 5)},
      {EllipsoidMesh(Vector3d(175, 115, 125), 28, 14),
       EllipsoidSolid(Vector3d(175, 115, 125), 28, 14)},
      {EllipsoidMesh(Vector3d(48, 50, 55), 16, 8), EllipsoidSolid(Vector3d(48, 50, 55), 16, 8)},
      {BoxMesh(Vector3d(100, 250, 85)), BoxSolid(Vector3d(100, 250, 85))},
  };
  for (const auto& c : cases) {
    int inside = 0;
    for (int i = 0; i < 20000; ++i) {
      const Vector3d p(rng.Uniform(-200, 200), rng.Uniform(-200, 200), rng.Uniform(-100, 900));
      if (!c.solid.Inside(p)) continue;
      ++inside;
      ASSERT_TRUE(InsideConvex(c.mesh, p)) << p.transpose();
    }
    EXPECT_GT(inside, 20);
  }
}

TEST(SceneMesh, RemoveBuriedFacesDropsOnlyEnclosedFaces) {
  SceneMesh mesh;
  Part big;
  big.name = "big";
  big.solid = EllipsoidSolid(Vector3d(200, 200, 200), 28, 14);
  mesh.AddPart(big, EllipsoidMesh(Vector3d(200, 200, 200), 28, 14));
  Part small = big;
  small.name = "small, inside";
  small.solid = EllipsoidSolid(Vector3d(50, 50, 50), 16, 8);
  small.translation_mm = Vector3d(20, 0, 0);
  mesh.AddPart(small, EllipsoidMesh(Vector3d(50, 50, 50), 16, 8));
  Part straddling = small;
  straddling.name = "straddling";
  straddling.translation_mm = Vector3d(200, 0, 0);
  mesh.AddPart(straddling, EllipsoidMesh(Vector3d(50, 50, 50), 16, 8));
  const size_t before = mesh.faces.size();
  const int removed = mesh.RemoveBuriedFaces();
  // All of the inner sphere's faces, some of each of the two straddling surfaces.
  EXPECT_GT(removed, 16 * 8 * 2 - 40);
  EXPECT_EQ(mesh.faces.size() + removed, before);
  std::vector<int> per_part(3, 0);
  for (auto p : mesh.face_part) ++per_part[p];
  EXPECT_EQ(per_part[1], 0);
  EXPECT_GT(per_part[0], 28 * 14 * 2 - 100);
  EXPECT_GT(per_part[2], 16 * 8);
  // Vertices were compacted: every vertex is used.
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& f : mesh.faces) used[f[0]] = used[f[1]] = used[f[2]] = 1;
  for (char u : used) EXPECT_TRUE(u);
  EXPECT_EQ(mesh.normals.size(), mesh.vertices.size());
}

TEST(SceneMesh, DomeSceneIsConsistent) {
  const SceneMesh mesh = BuildDomeScene(0.5);
  ASSERT_EQ(mesh.face_part.size(), mesh.faces.size());
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_GE(f[k], 0);
      ASSERT_LT(f[k], static_cast<int>(mesh.vertices.size()));
    }
  }
  bool has_bat = false, has_floor = false;
  for (const auto& p : mesh.parts) {
    has_bat |= p.name == "bat";
    has_floor |= p.name == "floor";
  }
  EXPECT_TRUE(has_bat);
  EXPECT_TRUE(has_floor);
  // Inside the room, above the floor.
  for (const auto& v : mesh.vertices) {
    EXPECT_GE(v.z(), -1e-3);
    EXPECT_LE(v.cwiseAbs().head<2>().maxCoeff(), kRoomHalfSizeMm + 1e-3);
  }
}

}  // namespace
}  // namespace dome::synth
