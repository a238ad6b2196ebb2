// Order statistics used by the evaluation reports.
#pragma once

#include <string>
#include <vector>

namespace dome::eval {

// The q-quantile (q in [0, 1]) with linear interpolation between order statistics,
// as numpy.percentile's default ("linear"): position q * (n - 1). Reorders `values`;
// NaN for an empty vector.
double Quantile(std::vector<double>& values, double q);

// Arithmetic mean; NaN for an empty vector.
double Mean(const std::vector<double>& values);

// Fraction of values <= threshold; NaN for an empty vector.
double FractionAtMost(const std::vector<double>& values, double threshold);

// Python's '%g' of `value` (0.5 -> "0.5", 1.0 -> "1"): the threshold in report keys
// such as "precision@1mm", spelled as the Python evaluator spells them.
std::string FormatG(double value);

}  // namespace dome::eval
