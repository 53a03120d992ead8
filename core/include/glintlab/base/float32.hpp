// The one rule that turns glintlab's float64 uniforms into the float32 numbers a shader receives.
//
// Rounding u to the nearest float (static_cast<float>) maps every u within 2^-25 of 1 to 1.0f, and a
// shader's `theta < P1` or `log(1 - u)` then sees an impossible uniform. The rule keeps the top 23
// bits of u and adds half a step: u32 = (floor(u 2^23) + 1/2) 2^-23, an odd multiple of 2^-24, so
// u32 lies in [2^-24, 1 - 2^-24] and is exactly representable (24 significant bits at most). The
// C++ float32 laws (detail::KernelLaw) and the Vulkan shader runner (validation/shader) apply the
// same rule, so a shader and its C++ twin see the same numbers and can be compared row by row.
// See docs/math/laws.md#float32-uniforms.
#pragma once

#include <cmath>

namespace glintlab {

inline float uniform_to_float(double u) {
  constexpr double kSteps = 8388608.0;  // 2^23
  double k = std::floor(u * kSteps);
  k = k < 0.0 ? 0.0 : (k > kSteps - 1.0 ? kSteps - 1.0 : k);  // u = 1 (and u = 0) stay inside
  return static_cast<float>((k + 0.5) / kSteps);
}

}  // namespace glintlab
