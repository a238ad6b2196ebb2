// Materials, procedural albedo and lighting of the synthetic dome.
//
// Every surface is Lambertian: radiance = albedo * (ambient + sum_i I_i max(0, n.l_i))
// under fixed directional lights (no shadows, no inter-reflection), so a surface point
// has the same brightness from every camera; views differ through each camera's gain,
// offset and noise (synth/render.h), as the seed's did.
//
// Albedo (0..1) is a deterministic function of the point in the part's *local* frame
// (mm), so texture moves with the body. Its finest detail is ~25-40 mm, i.e. 2-3
// pixels of the seed's 245x320 images at the dome's 2-3 m range: enough texture for
// stereo, coarse enough not to alias. The floor has a few deliberately textureless
// patches (the seed's stereo failed on such regions, Figure 9).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace dome::synth {

enum class Material : uint8_t {
  kFloor,       // textured floor tiles with textureless patches (world frame = local)
  kFloorMarks,  // the floor with the stage-2 calibration marks (synth/calib_target.h)
  kWall,        // distant background walls
  kSkin,        // neck, arms, hands
  kHead,        // face and hair
  kShirt,       // torso, upper arms
  kPants,       // pelvis, legs
  kShoe,
  kBat,         // wood with a taped handle
  kCalibPlate,  // stage-1 calibration object: white plates with black dots
  kBackdrop,    // stage-1 background: a plain lab wall
};

// Albedo at a point given in the part's local frame, in mm.
double Albedo(Material material, const Eigen::Vector3d& local_mm);

// True where the floor is deliberately textureless (world x, y in mm).
bool InTexturelessFloorPatch(double x_mm, double y_mm);

struct DirectionalLight {
  Eigen::Vector3d to_light;  // unit vector towards the light (world frame)
  double intensity = 0.0;    // irradiance factor for a surface facing it
};

struct Lighting {
  double ambient = 0.3;
  std::vector<DirectionalLight> lights;
  // Radiance of rays that hit nothing (open sky above the room walls).
  double sky_radiance = 0.12;

  // Lambertian radiance of a surface of the given albedo and unit normal.
  double Radiance(double albedo, const Eigen::Vector3d& normal) const {
    double irradiance = ambient;
    for (const auto& light : lights) {
      const double c = normal.dot(light.to_light);
      if (c > 0.0) irradiance += light.intensity * c;
    }
    return albedo * irradiance;
  }
};

// The dome's fixed lights (world frame): three lamps above and ambient light.
Lighting DomeLighting();
// The calibration bench's lights for stage 1, in the camera frame (x right, y down,
// z forward): lamps beside and above the camera.
Lighting BenchLighting();

}  // namespace dome::synth
