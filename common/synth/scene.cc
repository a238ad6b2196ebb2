#include "synth/scene.h"

#include "synth/batter.h"
#include "synth/calib_target.h"

namespace dome::synth {

using Eigen::Vector3d;

SceneMesh BuildRoom(bool floor_marks) {
  SceneMesh mesh;
  constexpr double h = kRoomHalfSizeMm;
  constexpr int kCells = 48;  // 250 mm floor / wall cells
  constexpr int kWallRows = 16;
  Part floor;
  floor.name = "floor";
  floor.material = floor_marks ? Material::kFloorMarks : Material::kFloor;
  mesh.AddPart(floor, GridMesh(Vector3d(-h, -h, 0), Vector3d::UnitX(), 2 * h, kCells,
                               Vector3d::UnitY(), 2 * h, kCells));
  struct WallSpec {
    const char* name;
    Vector3d origin, u;
  };
  const WallSpec walls[] = {
      {"wall +y", Vector3d(-h, h, 0), Vector3d(1, 0, 0)},
      {"wall -y", Vector3d(h, -h, 0), Vector3d(-1, 0, 0)},
      {"wall +x", Vector3d(h, h, 0), Vector3d(0, -1, 0)},
      {"wall -x", Vector3d(-h, -h, 0), Vector3d(0, 1, 0)},
  };
  for (const auto& w : walls) {
    Part wall;
    wall.name = w.name;
    wall.material = Material::kWall;
    mesh.AddPart(
        wall, GridMesh(w.origin, w.u, 2 * h, kCells, Vector3d::UnitZ(), kWallHeightMm, kWallRows));
  }
  return mesh;
}

SceneMesh BuildDomeScene(double time_s) {
  SceneMesh mesh = BuildRoom(false);
  AddBatter(PoseBatter(time_s), &mesh);
  mesh.RemoveBuriedFaces();
  return mesh;
}

SceneMesh BuildFloorMarkScene() { return BuildRoom(true); }

SceneMesh BuildBenchScene(const Eigen::Matrix3d& object_to_camera_rotation,
                          const Eigen::Vector3d& object_to_camera_translation_mm) {
  SceneMesh mesh;
  const Vector3d size(kPlateSizeMm, kPlateSizeMm, kPlateThicknessMm);
  const char* names[3] = {"plate z=0", "plate y=0", "plate x=0"};
  for (int plate = 0; plate < 3; ++plate) {
    Part part;
    part.name = names[plate];
    part.material = Material::kCalibPlate;
    part.rotation = object_to_camera_rotation * PlateRotation(plate);
    part.translation_mm = object_to_camera_translation_mm;
    // Plate-local: the dotted face at z = 0, the body below it.
    LocalMesh box = BoxMesh(size);
    for (auto& v : box.vertices)
      v += Vector3d(0.5 * kPlateSizeMm, 0.5 * kPlateSizeMm, -0.5 * kPlateThicknessMm);
    mesh.AddPart(part, box);
  }
  Part backdrop;
  backdrop.name = "backdrop";
  backdrop.material = Material::kBackdrop;
  constexpr double kBackdropDistanceMm = 3000.0, kHalf = 6000.0;
  // Facing the camera (-z): u x v = -z with u = +x, v = -y.
  mesh.AddPart(backdrop, GridMesh(Vector3d(-kHalf, kHalf, kBackdropDistanceMm), Vector3d::UnitX(),
                                  2 * kHalf, 8, -Vector3d::UnitY(), 2 * kHalf, 8));
  return mesh;
}

}  // namespace dome::synth
