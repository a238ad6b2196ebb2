#include "eval/statistics.h"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <limits>

namespace dome::eval {

double Quantile(std::vector<double>& values, double q) {
  if (values.empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double pos = std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const double frac = pos - static_cast<double>(lo);
  std::nth_element(values.begin(), values.begin() + lo, values.end());
  const double a = values[lo];
  if (frac == 0.0 || lo + 1 >= values.size()) {
    return a;
  }
  // After nth_element everything past lo is >= values[lo]; the next order statistic
  // is their minimum.
  const double b = *std::min_element(values.begin() + lo + 1, values.end());
  return a + (b - a) * frac;
}

double Mean(const std::vector<double>& values) {
  if (values.empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  double sum = 0.0;
  for (double v : values) {
    sum += v;
  }
  return sum / static_cast<double>(values.size());
}

double FractionAtMost(const std::vector<double>& values, double threshold) {
  if (values.empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  int64_t n = 0;
  for (double v : values) {
    n += v <= threshold ? 1 : 0;
  }
  return static_cast<double>(n) / static_cast<double>(values.size());
}

std::string FormatG(double value) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", value);
  return buf;
}

}  // namespace dome::eval
