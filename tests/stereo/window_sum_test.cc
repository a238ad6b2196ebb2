#include "stereo/window_sum.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace dome::stereo {
namespace {

// Every window the stereo options allow (1..31 px), rows of many lengths: integer values
// sum exactly in any order, so each box sum must equal the plain one; real values agree
// to float rounding.
TEST(WindowSum, EqualsThePlainBoxSum) {
  std::mt19937 rng(5);
  for (int h = 0; h <= 15; ++h) {
    for (int n : {1, 7, 16, 17, 31, 100, 333}) {
      const int total = n + 2 * h;
      std::vector<float> ints(total), reals(total);
      for (int i = 0; i < total; ++i) {
        ints[i] = float(rng() % 65536);
        reals[i] = std::uniform_real_distribution<float>(0.0f, 1000.0f)(rng);
      }
      std::vector<float> c(n);
      WindowSum(ints.data(), n, h, c.data());
      for (int x = 0; x < n; ++x) {
        double plain = 0;
        for (int d = 0; d <= 2 * h; ++d) plain += ints[x + d];
        ASSERT_EQ(double(c[x]), plain) << "h " << h << " n " << n << " x " << x;
      }
      WindowSum(reals.data(), n, h, c.data());
      for (int x = 0; x < n; ++x) {
        double plain = 0;
        for (int d = 0; d <= 2 * h; ++d) plain += reals[x + d];
        ASSERT_NEAR(c[x], plain, 1e-5 * plain) << "h " << h << " n " << n << " x " << x;
      }
    }
  }
}

}  // namespace
}  // namespace dome::stereo
