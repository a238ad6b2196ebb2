// Deterministic randomness for the synthetic dome.
//
// Two kinds, kept apart so that `--seed` changes the sensor noise and nothing else:
//  * Rng: a sequential SplitMix64 stream for the *scene* (camera placement jitter,
//    per-camera Tsai parameters, gain/offset). Seeded by fixed constants, never by
//    the user's seed.
//  * Counter-based hashes (HashKey, GaussianFromHash): the sensor noise of a pixel is
//    a pure function of (seed, image, pixel), so it is the same whatever the thread
//    count or the order in which pixels are rendered.
// GradientNoise is Perlin's improved noise (K. Perlin, "Improving Noise", SIGGRAPH
// 2002) with a fixed permutation: the procedural texture, identical for every seed.
#pragma once

#include <cstdint>

namespace dome::synth {

// SplitMix64's finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
inline uint64_t Mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Hash of a key extended by one more value (order matters).
inline uint64_t HashKey(uint64_t key, uint64_t value) { return Mix64(key ^ Mix64(value)); }

// Uniform in [0, 1) from the top 53 bits of a hash.
inline double UnitFromHash(uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

// Inverse standard-normal CDF sampled at 4097 points (i / 4096, the ends pulled in to
// 0.5 / 4096): the table behind GaussianSampler.
const float* InverseNormalTable();

// A standard normal deviate from a hash: the inverse normal CDF at a uniform quantile
// (24 bits of the hash), interpolated linearly in a 16 KB table that stays in the L1
// cache. Tails are cut at +-3.67 sigma, harmless for noise quantized to 8 bits.
class GaussianSampler {
 public:
  GaussianSampler() : table_(InverseNormalTable()) {}
  float operator()(uint64_t h) const {
    const uint32_t bits = static_cast<uint32_t>(h >> 40);  // 24 bits
    const uint32_t i = bits >> 12;
    const float f = static_cast<float>(bits & 4095u) * (1.0f / 4096.0f);
    return table_[i] + f * (table_[i + 1] - table_[i]);
  }

 private:
  const float* table_;
};

// GaussianSampler's deviate, without keeping a sampler.
float GaussianFromHash(uint64_t h);

// Sequential pseudo-random stream (SplitMix64).
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * UnitFromHash(Next()); }
  // Normal with the given mean and standard deviation.
  double Normal(double mean, double sigma) { return mean + sigma * GaussianFromHash(Next()); }

 private:
  uint64_t state_;
};

// Perlin's improved gradient noise at (x, y, z); smooth, zero at lattice points, values
// within about [-1, 1] (standard deviation ~0.2). Feature size ~1 lattice unit.
double GradientNoise(double x, double y, double z);
// The same in two dimensions (for flat surfaces: half the work), values within about
// [-1, 1].
double GradientNoise2(double x, double y);

}  // namespace dome::synth
