// The horizontal box sums of the stereo cost kernel (cost_kernel.cc), declared here so
// that a test can check them against plain sums.
#pragma once

namespace dome::stereo {

// c[x] = sum of v[x..x+2h] for x in [0, n); v holds n + 2h values. Windows of 9 or more
// are summed as sums of sums (2, 4, 8, ... values), so the float rounding differs from
// adding value by value; the order depends only on the window, never on the CPU.
void WindowSum(const float* v, int n, int h, float* c);

}  // namespace dome::stereo
