#include "synth/texture.h"

#include <algorithm>
#include <cmath>

#include "synth/calib_target.h"
#include "synth/noise.h"

namespace dome::synth {
namespace {

// Band-limited noise with features of about `scale_mm`, offset per use so that
// different materials do not share a pattern.
double Noise(const Eigen::Vector3d& p, double scale_mm, double offset) {
  return GradientNoise(p.x() / scale_mm + offset, p.y() / scale_mm + 1.7 * offset,
                       p.z() / scale_mm - 0.9 * offset);
}

double Noise2(double u, double v, double scale_mm, double offset) {
  return GradientNoise2(u / scale_mm + offset, v / scale_mm - 0.6 * offset);
}

double Clamp01(double a) { return std::clamp(a, 0.02, 0.95); }

struct Patch {
  double x_mm, y_mm, radius_mm;
};
// Textureless floor patches, placed where most cameras see them near the person.
constexpr Patch kPatches[] = {
    {1250.0, -750.0, 380.0}, {-1100.0, 950.0, 420.0}, {500.0, 1450.0, 300.0}};
constexpr double kPatchAlbedo = 0.55;

double FloorAlbedo(const Eigen::Vector3d& p) {
  if (InTexturelessFloorPatch(p.x(), p.y())) return kPatchAlbedo;
  // The floor is flat (z = 0): 2D noise.
  double a = 0.42 + 0.3 * Noise2(p.x(), p.y(), 90.0, 3.1) + 0.2 * Noise2(p.x(), p.y(), 35.0, 7.3);
  // Tiles with grout lines, 600 mm pitch, 25 mm wide.
  const double gx = std::abs(p.x() - 600.0 * std::floor(p.x() / 600.0 + 0.5));
  const double gy = std::abs(p.y() - 600.0 * std::floor(p.y() / 600.0 + 0.5));
  if (std::min(gx, gy) < 12.5) a *= 0.55;
  return Clamp01(a);
}

double HeadAlbedo(const Eigen::Vector3d& p) {
  // Local frame: z up, y forward (face). Hair on top and at the back.
  const bool hair = p.z() > 45.0 || (p.y() < -30.0 && p.z() > -40.0);
  if (hair) return Clamp01(0.14 + 0.25 * Noise(p, 25.0, 5.5));
  double a = 0.62 + 0.3 * Noise(p, 28.0, 1.9);
  // Eyes and mouth: dark spots on the face.
  const double ex = std::abs(p.x()) - 32.0, ez = p.z() - 12.0;
  if (p.y() > 40.0 && ex * ex + ez * ez < 14.0 * 14.0) a = 0.18;
  if (p.y() > 40.0 && std::abs(p.x()) < 25.0 && std::abs(p.z() + 45.0) < 7.0) a = 0.3;
  return Clamp01(a);
}

}  // namespace

bool InTexturelessFloorPatch(double x_mm, double y_mm) {
  for (const auto& patch : kPatches) {
    const double dx = x_mm - patch.x_mm, dy = y_mm - patch.y_mm;
    if (dx * dx + dy * dy < patch.radius_mm * patch.radius_mm) return true;
  }
  return false;
}

double Albedo(Material material, const Eigen::Vector3d& p) {
  switch (material) {
    case Material::kFloor:
      return FloorAlbedo(p);
    case Material::kFloorMarks:
      return FloorMarksAlbedo(p.x(), p.y(), FloorAlbedo(p));
    case Material::kWall: {
      // Walls are vertical planes x = +-h or y = +-h: noise over (x + y, z).
      const double u = p.x() + p.y();
      return Clamp01(0.5 + 0.45 * Noise2(u, p.z(), 300.0, 11.0) +
                     0.27 * Noise2(u, p.z(), 70.0, 13.0));
    }
    case Material::kSkin:
      return Clamp01(0.66 + 0.35 * Noise(p, 30.0, 2.3));
    case Material::kHead:
      return HeadAlbedo(p);
    case Material::kShirt: {
      // Horizontal stripes (in the part's frame) over a blotchy print.
      const double stripes = 0.16 * std::sin(2.0 * M_PI * p.z() / 110.0);
      return Clamp01(0.62 + stripes + 0.5 * Noise(p, 45.0, 17.0) + 0.3 * Noise(p, 25.0, 4.1));
    }
    case Material::kPants:
      return Clamp01(0.36 + 0.45 * Noise(p, 40.0, 23.0) + 0.25 * Noise(p, 25.0, 29.0));
    case Material::kShoe:
      return Clamp01(0.15 + 0.3 * Noise(p, 30.0, 31.0));
    case Material::kBat: {
      // Local z along the bat from the knob; tape on the handle.
      if (p.z() < 280.0) {
        const double phase = p.z() / 35.0 + std::atan2(p.y(), p.x()) / (2.0 * M_PI);
        return Clamp01(0.22 + 0.12 * std::sin(2.0 * M_PI * phase));
      }
      const Eigen::Vector3d grain(p.x() / 12.0, p.y() / 12.0, p.z() / 160.0);
      return Clamp01(0.72 + 0.5 * GradientNoise(grain.x() + 37.0, grain.y(), grain.z()) +
                     0.25 * Noise(p, 30.0, 41.0));
    }
    case Material::kCalibPlate:
      return CalibPlateAlbedo(p.x(), p.y());
    case Material::kBackdrop:
      return Clamp01(0.4 + 0.15 * Noise(p, 400.0, 43.0));
  }
  return 0.5;
}

Lighting DomeLighting() {
  Lighting lighting;
  lighting.ambient = 0.32;
  lighting.lights = {
      {Eigen::Vector3d(0.35, -0.45, 0.82).normalized(), 0.55},
      {Eigen::Vector3d(-0.6, 0.3, 0.74).normalized(), 0.35},
      {Eigen::Vector3d(0.2, 0.75, 0.63).normalized(), 0.2},
  };
  lighting.sky_radiance = 0.12;
  return lighting;
}

Lighting BenchLighting() {
  Lighting lighting;
  lighting.ambient = 0.35;
  lighting.lights = {
      {Eigen::Vector3d(-0.3, -0.5, -0.81).normalized(), 0.55},
      {Eigen::Vector3d(0.45, -0.2, -0.87).normalized(), 0.3},
  };
  lighting.sky_radiance = 0.1;
  return lighting;
}

}  // namespace dome::synth
