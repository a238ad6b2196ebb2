#include "synth/noise.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dome::synth {
namespace {

TEST(Noise, GaussianSamplerHasUnitNormalMoments) {
  const GaussianSampler gaussian;
  double sum = 0, sum2 = 0, sum4 = 0, max_abs = 0;
  int beyond_2sigma = 0;
  const int n = 1 << 20;
  for (int i = 0; i < n; ++i) {
    const double z = gaussian(HashKey(42, i));
    sum += z;
    sum2 += z * z;
    sum4 += z * z * z * z;
    max_abs = std::max(max_abs, std::abs(z));
    if (std::abs(z) > 2.0) ++beyond_2sigma;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.005);
  EXPECT_NEAR(sum2 / n, 1.0, 0.01);
  EXPECT_NEAR(sum4 / n, 3.0, 0.06);  // kurtosis of a normal
  EXPECT_NEAR(static_cast<double>(beyond_2sigma) / n, 0.0455, 0.002);
  EXPECT_LE(max_abs, 3.7);  // the table's tails end at +-3.67
  EXPECT_GE(max_abs, 3.3);
}

TEST(Noise, HashesAreDeterministicAndSpread) {
  EXPECT_EQ(HashKey(1, 2), HashKey(1, 2));
  EXPECT_NE(HashKey(1, 2), HashKey(2, 1));
  EXPECT_NE(HashKey(1, 2), HashKey(1, 3));
  double mean = 0;
  for (int i = 0; i < 10000; ++i) mean += UnitFromHash(Mix64(i));
  EXPECT_NEAR(mean / 10000, 0.5, 0.01);
}

TEST(Noise, RngIsReproducible) {
  Rng a(7), b(7), c(8);
  for (int i = 0; i < 10; ++i) {
    const double x = a.Uniform(0, 1);
    EXPECT_EQ(x, b.Uniform(0, 1));
    EXPECT_NE(x, c.Uniform(0, 1));
  }
}

TEST(Noise, GradientNoiseIsSmoothAndBounded) {
  EXPECT_EQ(GradientNoise(3, 4, 5), 0.0);  // zero on the lattice
  double sum2 = 0;
  int n = 0;
  for (double x = 0.05; x < 20; x += 0.37) {
    for (double y = 0.11; y < 20; y += 0.41) {
      const double v = GradientNoise(x, y, 0.5 * x + 0.3);
      EXPECT_LE(std::abs(v), 1.1);
      // Lipschitz: a small step changes the value a little.
      EXPECT_LE(std::abs(GradientNoise(x + 1e-3, y, 0.5 * x + 0.3) - v), 5e-3);
      sum2 += v * v;
      ++n;
    }
  }
  const double sd = std::sqrt(sum2 / n);
  EXPECT_GT(sd, 0.1);
  EXPECT_LT(sd, 0.5);
}

}  // namespace
}  // namespace dome::synth

namespace dome::synth {
namespace {

TEST(Noise, GradientNoise2IsSmoothAndBounded) {
  EXPECT_EQ(GradientNoise2(3, 4), 0.0);
  double sum2 = 0;
  int n = 0;
  for (double x = 0.05; x < 30; x += 0.29) {
    for (double y = 0.11; y < 30; y += 0.31) {
      const double v = GradientNoise2(x, y);
      EXPECT_LE(std::abs(v), 1.1);
      EXPECT_LE(std::abs(GradientNoise2(x, y + 1e-3) - v), 5e-3);
      sum2 += v * v;
      ++n;
    }
  }
  EXPECT_GT(std::sqrt(sum2 / n), 0.15);
  EXPECT_LT(std::sqrt(sum2 / n), 0.5);
}

}  // namespace
}  // namespace dome::synth
