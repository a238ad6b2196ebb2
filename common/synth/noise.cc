#include "synth/noise.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace dome::synth {
namespace {

// Inverse of the standard normal CDF: Acklam's rational approximation (relative error
// < 1.2e-9), refined by one Halley step on erfc.
double InverseNormalCdf(double p) {
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,
                                 -2.759285104469687e+02, 1.383577518672690e+02,
                                 -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02,
                                 -1.556989798598866e+02, 6.680131188771972e+01,
                                 -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01,
                                 -2.400758277161838e+00, -2.549732539343734e+00,
                                 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01,
                                 2.445134137142996e+00, 3.754408661907416e+00};
  const double p_low = 0.02425;
  double x;
  if (p < p_low) {
    const double q = std::sqrt(-2 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  } else if (p <= 1 - p_low) {
    const double q = p - 0.5;
    const double r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  } else {
    const double q = std::sqrt(-2 * std::log(1 - p));
    x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  const double e = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
  const double u = e * std::sqrt(2 * M_PI) * std::exp(x * x / 2);
  return x - u / (1 + x * u / 2);
}

struct GaussianTable {
  std::array<float, 4097> values;
  GaussianTable() {
    for (int i = 0; i <= 4096; ++i) {
      const double p = std::clamp(i / 4096.0, 0.5 / 4096.0, 1.0 - 0.5 / 4096.0);
      values[i] = static_cast<float>(InverseNormalCdf(p));
    }
  }
};

// Perlin's reference permutation is replaced by one drawn from a fixed stream, so
// the texture is ours yet never depends on the user's seed.
struct Permutation {
  std::array<uint8_t, 512> p;
  Permutation() {
    std::array<uint8_t, 256> base;
    for (int i = 0; i < 256; ++i) base[i] = static_cast<uint8_t>(i);
    Rng rng(0x5eed0fd0e5ULL);
    for (int i = 255; i > 0; --i) {
      const int j = static_cast<int>(rng.Next() % static_cast<uint64_t>(i + 1));
      std::swap(base[i], base[j]);
    }
    for (int i = 0; i < 512; ++i) p[i] = base[i & 255];
  }
};

// Built once at start-up; a namespace-scope table keeps the hot noise functions free
// of function-local static guards.
const Permutation kPermutation;

inline double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
inline double Lerp(double t, double a, double b) { return a + t * (b - a); }
inline double Grad(int hash, double x, double y, double z) {
  const int h = hash & 15;
  const double u = h < 8 ? x : y;
  const double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
  return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

inline double Grad2(int hash, double x, double y) {
  switch (hash & 7) {
    case 0:
      return x + y;
    case 1:
      return -x + y;
    case 2:
      return x - y;
    case 3:
      return -x - y;
    case 4:
      return x;
    case 5:
      return -x;
    case 6:
      return y;
    default:
      return -y;
  }
}

}  // namespace

double GradientNoise2(double x, double y) {
  const auto& p = kPermutation.p;
  const double fx = std::floor(x), fy = std::floor(y);
  const int X = static_cast<int>(static_cast<int64_t>(fx) & 255);
  const int Y = static_cast<int>(static_cast<int64_t>(fy) & 255);
  x -= fx;
  y -= fy;
  const double u = Fade(x), v = Fade(y);
  const int A = p[X] + Y, B = p[X + 1] + Y;
  return Lerp(v, Lerp(u, Grad2(p[A], x, y), Grad2(p[B], x - 1, y)),
              Lerp(u, Grad2(p[A + 1], x, y - 1), Grad2(p[B + 1], x - 1, y - 1)));
}

const float* InverseNormalTable() {
  static const GaussianTable table;
  return table.values.data();
}

float GaussianFromHash(uint64_t h) { return GaussianSampler()(h); }

double GradientNoise(double x, double y, double z) {
  const auto& p = kPermutation.p;
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int X = static_cast<int>(static_cast<int64_t>(fx) & 255);
  const int Y = static_cast<int>(static_cast<int64_t>(fy) & 255);
  const int Z = static_cast<int>(static_cast<int64_t>(fz) & 255);
  x -= fx;
  y -= fy;
  z -= fz;
  const double u = Fade(x), v = Fade(y), w = Fade(z);
  const int A = p[X] + Y, AA = p[A] + Z, AB = p[A + 1] + Z;
  const int B = p[X + 1] + Y, BA = p[B] + Z, BB = p[B + 1] + Z;
  return Lerp(
      w,
      Lerp(v, Lerp(u, Grad(p[AA], x, y, z), Grad(p[BA], x - 1, y, z)),
           Lerp(u, Grad(p[AB], x, y - 1, z), Grad(p[BB], x - 1, y - 1, z))),
      Lerp(v, Lerp(u, Grad(p[AA + 1], x, y, z - 1), Grad(p[BA + 1], x - 1, y, z - 1)),
           Lerp(u, Grad(p[AB + 1], x, y - 1, z - 1), Grad(p[BB + 1], x - 1, y - 1, z - 1))));
}

}  // namespace dome::synth
