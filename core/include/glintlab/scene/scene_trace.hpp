// Camera rays against a scene's one primitive (a sphere, a plane, a plane displaced by a sum of sine
// waves), per pixel: the first hit, the ray parameter, uv and its analytic Jacobian, the shading normal
// and the hit point's derivatives along the pixel axes. The C++ form of glintlab.validation.scene's
// Scene.trace (whose docstring derives the implicit-function derivatives), the same operations in
// float64, so that the two agree to float64 rounding; rays are independent, so the result does not
// depend on the thread count.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace glintlab::images {

struct TraceScene {
  bool sphere = false;                      // else a plane (displaced when `waves` is not empty)
  double width = 0, height = 0, focal = 0;  // pixels; focal length in pixels
  std::array<double, 3> position{}, forward{}, right{}, up{};
  std::array<double, 3> center{};  // sphere
  double radius = 0;
  std::array<double, 3> origin{}, normal{}, e1{}, e2{};  // plane and its frame
  std::vector<std::array<double, 5>> waves;              // (amplitude, angular frequency, cos, sin, phase)
  double uv_scale = 1;
};

// Outputs per ray, each an array the caller owns: hit (1 / 0), t (1 where missed), x (3), uv (2, 0 where
// missed), J (4, 0 where missed), shading normal (3), direction (3, not normalised), dxdpx (3), dxdpy (3).
struct TraceOut {
  std::uint8_t* hit;
  double *t, *x, *uv, *J, *shading, *direction, *dxdpx, *dxdpy;
};

// Rays through pixel coordinates (px[i], py[i]) (pixel centres at i + 0.5, y down). Throws
// std::invalid_argument for a degenerate scene (focal <= 0, radius <= 0).
void trace(const TraceScene& scene, const double* px, const double* py, std::size_t count, const TraceOut& out);

}  // namespace glintlab::images
