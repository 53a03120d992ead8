// Scene.trace in C++ (core/include/glintlab/scene_trace.hpp): per ray, the operations of
// glintlab/validation/scene.py in the same order (the heightfield's conservative march, then Newton
// safeguarded by bisection), so that the two agree to float64 rounding. The differences that remain are
// last places: numpy's vector sin, cos and atan2 against the C library's, and its matrix products'
// summation order.
#include "glintlab/scene_trace.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "glintlab/errors.hpp"
#include "parallel.hpp"

namespace glintlab::images {
namespace {

using V3 = std::array<double, 3>;

V3 sub(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void put(double* out, std::size_t i, const V3& v) {
  out[3 * i] = v[0];
  out[3 * i + 1] = v[1];
  out[3 * i + 2] = v[2];
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Height {
  double h = 0, ha = 0, hb = 0;
};

// The height above the plane and its gradient in the plane's frame (Scene._height).
Height height(const TraceScene& s, double a, double b) {
  Height out;
  for (const auto& w : s.waves) {
    const double arg = w[1] * (w[2] * a + w[3] * b) + w[4];
    // One sincos for both (the C library's sin and cos, the same values; half the argument reductions).
    double sn, cs;
    ::sincos(arg, &sn, &cs);
    out.h += w[0] * sn;
    const double c = w[0] * w[1] * cs;
    out.ha += c * w[2];
    out.hb += c * w[3];
  }
  return out;
}

// First t > 0 where the ray meets the heightfield (Scene._intersect_heightfield and Scene._refine).
double intersect_heightfield(const TraceScene& s, const V3& d) {
  double amax = 0, slope = 0, wmax = 0;
  for (const auto& w : s.waves) {
    amax += w[0];
    slope += w[0] * w[1];
    wmax = std::max(wmax, w[1]);
  }
  const V3 rel = sub(s.position, s.origin);
  const double c0 = dot(rel, s.normal), dn = dot(d, s.normal), da = dot(d, s.e1), db = dot(d, s.e2);
  const double a0 = dot(rel, s.e1), b0 = dot(rel, s.e2);
  if (!(dn < 0)) return kNaN;
  const double t_top = std::max((amax - c0) / dn, 0.0), t_bot = (-amax - c0) / dn;
  const double lip = std::abs(dn) + slope * std::hypot(da, db);
  double min_step = (!s.waves.empty() && slope > 0)
                        ? (2 * std::numbers::pi / wmax) / 8 / std::max(std::hypot(da, db), 1e-12)
                        : std::numeric_limits<double>::infinity();
  min_step = std::min(min_step, (t_bot - t_top) / 4);
  auto G = [&](double t, double& dg) {
    const Height h = height(s, a0 + t * da, b0 + t * db);
    dg = dn - h.ha * da - h.hb * db;
    return c0 + t * dn - h.h;
  };
  // The march: bracket [lo, t] with G(lo) > 0 >= G(t) (t_bot always has G <= 0).
  double t = t_top, lo = t, br_lo = kNaN, br_hi = kNaN, dg;
  for (int k = 0; k < 10'000; ++k) {
    const double g = G(t, dg);
    if (g <= 0 || t >= t_bot) {
      br_lo = lo;
      br_hi = std::min(t, t_bot);
      break;
    }
    lo = t;
    t = std::min(t + std::max(g / lip, min_step), t_bot);
  }
  if (!std::isfinite(br_lo)) return kNaN;
  // Newton inside the bracket, bisection otherwise, until the step is below 1e-15 t (80 rounds at most).
  double out = 0.5 * (br_lo + br_hi), hi = br_hi;
  lo = br_lo;
  t = out;
  for (int k = 0; k < 80; ++k) {
    const double g = G(t, dg);
    if (g > 0)
      lo = t;
    else
      hi = t;
    const double tn = t - g / dg;
    const bool inside = std::isfinite(tn) && tn >= lo && tn <= hi;
    const double t_new = inside ? tn : 0.5 * (lo + hi);
    const bool conv = std::abs(t_new - t) <= 1e-15 * std::abs(t) || hi - lo <= 1e-15 * std::abs(t);
    out = t_new;
    if (conv) break;
    t = t_new;
  }
  return out;
}

void trace_one(const TraceScene& s, double px, double py, std::size_t i, const TraceOut& o) {
  const double xs = (px - 0.5 * s.width) / s.focal, ys = (py - 0.5 * s.height) / s.focal;
  const V3 d{s.forward[0] + xs * s.right[0] - ys * s.up[0], s.forward[1] + xs * s.right[1] - ys * s.up[1],
             s.forward[2] + xs * s.right[2] - ys * s.up[2]};
  // d d / d px and d d / d py: right / focal and -up / focal.
  const V3 dd0{s.right[0] / s.focal, s.right[1] / s.focal, s.right[2] / s.focal};
  const V3 dd1{-s.up[0] / s.focal, -s.up[1] / s.focal, -s.up[2] / s.focal};
  const V3& o_ = s.position;
  double t;
  if (s.sphere) {
    const V3 oc = sub(o_, s.center);
    const double a = dot(d, d), b = 2 * dot(d, oc), c = dot(oc, oc) - s.radius * s.radius;
    const double disc = b * b - 4 * a * c;
    // The nearest root as 2c / (-b + sqrt(disc)): no cancellation (c > 0, the camera is outside).
    t = disc >= 0 ? 2 * c / (-b + std::sqrt(std::max(disc, 0.0))) : kNaN;
  } else if (!s.waves.empty()) {
    t = intersect_heightfield(s, d);
  } else {
    t = dot(sub(s.origin, o_), s.normal) / dot(d, s.normal);
  }
  const bool hit = std::isfinite(t) && t > 0;
  if (!hit) t = 1.0;
  const V3 x{o_[0] + t * d[0], o_[1] + t * d[1], o_[2] + t * d[2]};
  V3 g, shading;
  double a = 0, b = 0;
  if (s.sphere) {
    g = {(x[0] - s.center[0]) / s.radius, (x[1] - s.center[1]) / s.radius, (x[2] - s.center[2]) / s.radius};
    shading = g;
  } else {
    const V3 rel = sub(x, s.origin);
    a = dot(rel, s.e1);
    b = dot(rel, s.e2);
    if (!s.waves.empty()) {
      const Height h = height(s, a, b);
      g = {s.normal[0] - h.ha * s.e1[0] - h.hb * s.e2[0], s.normal[1] - h.ha * s.e1[1] - h.hb * s.e2[1],
           s.normal[2] - h.ha * s.e1[2] - h.hb * s.e2[2]};
    } else {
      g = s.normal;
    }
    const double len = std::sqrt(dot(g, g));
    shading = {g[0] / len, g[1] / len, g[2] / len};
  }
  // dx/dq = t (dd/dq - d (g . dd/dq) / (g . d)) (scene.py's module docstring).
  const double gd = dot(g, d);
  V3 dx[2];
  const V3* ddq[2] = {&dd0, &dd1};
  for (int k = 0; k < 2; ++k) {
    const V3& v = *ddq[k];
    const double r = dot(g, v) / gd;
    dx[k] = {t * (v[0] - d[0] * r), t * (v[1] - d[1] * r), t * (v[2] - d[2] * r)};
  }
  const double sc = s.uv_scale;
  double uv[2], J[4];
  if (s.sphere) {
    // Arc-length lat-long: u = s R phi, v = s R theta, the pole along +z.
    const V3 q = sub(x, s.center);
    const double rho2 = q[0] * q[0] + q[1] * q[1], rho = std::sqrt(rho2), sr = sc * s.radius;
    uv[0] = sr * std::atan2(q[1], q[0]);
    uv[1] = sr * std::atan2(rho, q[2]);
    const V3 grad_phi{-q[1] / rho2, q[0] / rho2, 0.0 / rho2};
    const double r2 = rho2 + q[2] * q[2];
    const V3 grad_th{q[2] * q[0] / rho / r2, q[2] * q[1] / rho / r2, -rho / r2};
    J[0] = sr * dot(grad_phi, dx[0]);
    J[1] = sr * dot(grad_th, dx[0]);
    J[2] = sr * dot(grad_phi, dx[1]);
    J[3] = sr * dot(grad_th, dx[1]);
  } else {
    uv[0] = sc * a;
    uv[1] = sc * b;
    J[0] = sc * dot(dx[0], s.e1);
    J[1] = sc * dot(dx[0], s.e2);
    J[2] = sc * dot(dx[1], s.e1);
    J[3] = sc * dot(dx[1], s.e2);
  }
  o.hit[i] = hit ? 1 : 0;
  o.t[i] = t;
  put(o.x, i, x);
  for (int k = 0; k < 2; ++k) o.uv[2 * i + k] = hit ? uv[k] : 0.0;
  for (int k = 0; k < 4; ++k) o.J[4 * i + k] = hit ? J[k] : 0.0;
  put(o.shading, i, shading);
  put(o.direction, i, d);
  put(o.dxdpx, i, dx[0]);
  put(o.dxdpy, i, dx[1]);
}

}  // namespace

void trace(const TraceScene& scene, const double* px, const double* py, std::size_t count, const TraceOut& out) {
  if (!(scene.focal > 0)) glintlab::throw_invalid("trace", "focal", scene.focal, "a focal length > 0 (pixels)");
  if (scene.sphere && !(scene.radius > 0)) glintlab::throw_invalid("trace", "radius", scene.radius, "a radius > 0");
  detail::parallel_chunks(count, 2048, 8192, [&](std::size_t i0, std::size_t i1) {
    for (std::size_t i = i0; i < i1; ++i) trace_one(scene, px[i], py[i], i, out);
  });
}

}  // namespace glintlab::images
