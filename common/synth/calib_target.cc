#include "synth/calib_target.h"

#include <algorithm>
#include <cmath>

namespace dome::synth {
namespace {

// Black dot of radius r on white whose edge is a linear ramp `ramp_mm` wide: the dot
// as seen through a box filter about a pixel's footprint wide. The renderer point
// samples (synth/render.h); a sharp outline would alias into a jagged one whose
// centroid is off by up to a tenth of a pixel, the same in every frame, while the
// ramp keeps the dot's centre (and its darkness integral) where they are.
double Dot(double distance_mm, double radius_mm, double ramp_mm, double dark, double light) {
  const double a = std::clamp((distance_mm - radius_mm) / ramp_mm + 0.5, 0.0, 1.0);
  return dark + (light - dark) * a;
}

// Footprints of a take-image pixel: ~6 mm on the plates at the bench's ~1 m, ~18 mm
// (more along a grazing view) on the floor from the dome's ~3 m.
constexpr double kPlateRampMm = 8.0;
constexpr double kFloorRampMm = 24.0;

}  // namespace

Eigen::Matrix3d PlateRotation(int plate) {
  Eigen::Matrix3d r;
  switch (plate) {
    case 0:  // face z = 0: local x, y = object x, y
      r << 1, 0, 0, 0, 1, 0, 0, 0, 1;
      break;
    case 1:  // face y = 0: local x = object z, local y = object x, local z = object y
      r << 0, 1, 0, 0, 0, 1, 1, 0, 0;
      break;
    default:  // face x = 0: local x = object y, local y = object z, local z = object x
      r << 0, 0, 1, 1, 0, 0, 0, 1, 0;
      break;
  }
  return r;
}

std::vector<TargetPoint> CalibObjectPoints() {
  std::vector<TargetPoint> points;
  for (int plate = 0; plate < 3; ++plate) {
    const Eigen::Matrix3d r = PlateRotation(plate);
    for (int j = 1; j <= kPlateDotsPerSide; ++j) {
      for (int i = 1; i <= kPlateDotsPerSide; ++i) {
        TargetPoint p;
        p.id = 49 * plate + 7 * (j - 1) + (i - 1);
        p.position_mm = r * Eigen::Vector3d(kPlateDotPitchMm * i, kPlateDotPitchMm * j, 0.0);
        points.push_back(p);
      }
    }
  }
  return points;
}

double CalibPlateAlbedo(double x_mm, double y_mm) {
  constexpr double kWhite = 0.85, kBlack = 0.05;
  const int i = static_cast<int>(std::lround(x_mm / kPlateDotPitchMm));
  const int j = static_cast<int>(std::lround(y_mm / kPlateDotPitchMm));
  if (i < 1 || i > kPlateDotsPerSide || j < 1 || j > kPlateDotsPerSide) return kWhite;
  const double d = std::hypot(x_mm - kPlateDotPitchMm * i, y_mm - kPlateDotPitchMm * j);
  const double radius = (i == 1 && j == 1) ? kPlateKeyDotRadiusMm : kPlateDotRadiusMm;
  return Dot(d, radius, kPlateRampMm, kBlack, kWhite);
}

std::vector<TargetPoint> FloorMarkPoints() {
  std::vector<TargetPoint> points;
  const double half = 0.5 * (kFloorMarksPerSide - 1) * kFloorMarkPitchMm;
  for (int row = 0; row < kFloorMarksPerSide; ++row) {
    for (int col = 0; col < kFloorMarksPerSide; ++col) {
      TargetPoint p;
      p.id = kFloorMarksPerSide * row + col;
      p.position_mm = {-half + kFloorMarkPitchMm * col, -half + kFloorMarkPitchMm * row, 0.0};
      points.push_back(p);
    }
  }
  return points;
}

std::vector<TargetPoint> AllFloorMarkPoints() {
  std::vector<TargetPoint> points = FloorMarkPoints();
  int id = static_cast<int>(points.size());
  for (int ring = 0; ring < kFloorRings; ++ring) {
    for (int m = 0; m < kFloorRingMarks[ring]; ++m) {
      const double angle = 2.0 * M_PI * (m + 0.5) / kFloorRingMarks[ring];
      TargetPoint p;
      p.id = id++;
      p.position_mm = {kFloorRingRadiusMm[ring] * std::cos(angle),
                       kFloorRingRadiusMm[ring] * std::sin(angle), 0.0};
      points.push_back(p);
    }
  }
  return points;
}

double FloorMarksAlbedo(double x_mm, double y_mm, double floor_albedo) {
  constexpr double kWhite = 0.9, kBlack = 0.04;
  const double half = 0.5 * (kFloorMarksPerSide - 1) * kFloorMarkPitchMm;
  const int col = static_cast<int>(std::lround((x_mm + half) / kFloorMarkPitchMm));
  const int row = static_cast<int>(std::lround((y_mm + half) / kFloorMarkPitchMm));
  double d = 0, radius = kFloorMarkDotRadiusMm;
  if (col >= 0 && col < kFloorMarksPerSide && row >= 0 && row < kFloorMarksPerSide) {
    d = std::hypot(x_mm - (-half + kFloorMarkPitchMm * col),
                   y_mm - (-half + kFloorMarkPitchMm * row));
    if (row == 0 && col == 0) radius = kFloorMarkKeyDotRadiusMm;
  } else {
    // the nearest ring, and on it the nearest mark
    const double r = std::hypot(x_mm, y_mm);
    int ring = 0;
    for (int k = 1; k < kFloorRings; ++k) {
      if (std::abs(r - kFloorRingRadiusMm[k]) < std::abs(r - kFloorRingRadiusMm[ring])) ring = k;
    }
    if (std::abs(r - kFloorRingRadiusMm[ring]) > kFloorMarkPadRadiusMm + kFloorRampMm) {
      return floor_albedo;
    }
    const double step = 2.0 * M_PI / kFloorRingMarks[ring];
    const double m = std::round(std::atan2(y_mm, x_mm) / step - 0.5);
    const double angle = (m + 0.5) * step;
    d = std::hypot(x_mm - kFloorRingRadiusMm[ring] * std::cos(angle),
                   y_mm - kFloorRingRadiusMm[ring] * std::sin(angle));
  }
  if (d > kFloorMarkPadRadiusMm + 0.5 * kFloorRampMm) return floor_albedo;
  const double pad = Dot(d, kFloorMarkPadRadiusMm, kFloorRampMm, kWhite, floor_albedo);
  return d < radius + 0.5 * kFloorRampMm ? Dot(d, radius, kFloorRampMm, kBlack, kWhite) : pad;
}

}  // namespace dome::synth
