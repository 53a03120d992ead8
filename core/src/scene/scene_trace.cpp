// Scene.trace in C++ (core/include/glintlab/scene/scene_trace.hpp): per ray, the operations of
// glintlab/validation/scene.py in the same order (the heightfield's conservative march, then Newton
// safeguarded by bisection), so that the two agree to float64 rounding. The differences that remain are
// last places: numpy's vector sin, cos and atan2 against the C library's (and SLEEF's in the march),
// and its matrix products' summation order.
#include "glintlab/scene/scene_trace.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "simd/simd_math.hpp"

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

V3 ray_direction(const TraceScene& s, double px, double py) {
  const double xs = (px - 0.5 * s.width) / s.focal, ys = (py - 0.5 * s.height) / s.focal;
  return {s.forward[0] + xs * s.right[0] - ys * s.up[0], s.forward[1] + xs * s.right[1] - ys * s.up[1],
          s.forward[2] + xs * s.right[2] - ys * s.up[2]};
}

// First t > 0 where each of `m` rays meets the heightfield (Scene._intersect_heightfield and
// Scene._refine), NaN where none does. The rays of a block advance in lockstep, as numpy's arrays do,
// so that each round's sines and cosines are one vector call (SLEEF, 1 ulp: the values agree with the
// numpy form's to float64 rounding); every ray's own sequence of steps is the scalar algorithm's.
void heightfield_hits(const TraceScene& s, const double* px, const double* py, std::size_t m, double* out) {
  double amax = 0, slope = 0, wmax = 0;
  for (const auto& w : s.waves) {
    amax += w[0];
    slope += w[0] * w[1];
    wmax = std::max(wmax, w[1]);
  }
  const V3 rel = sub(s.position, s.origin);
  const double c0 = dot(rel, s.normal), a0 = dot(rel, s.e1), b0 = dot(rel, s.e2);
  std::vector<double> dn(m), da(m), db(m), t(m), lo(m), hi(m), t_bot(m), lip(m), min_step(m), g(m), dg(m);
  std::vector<double> br_lo(m, kNaN), br_hi(m, kNaN);
  std::vector<std::size_t> act, keep;
  act.reserve(m);
  keep.reserve(m);
  for (std::size_t j = 0; j < m; ++j) {
    out[j] = kNaN;
    const V3 d = ray_direction(s, px[j], py[j]);
    dn[j] = dot(d, s.normal);
    da[j] = dot(d, s.e1);
    db[j] = dot(d, s.e2);
    if (!(dn[j] < 0)) continue;
    const double t_top = std::max((amax - c0) / dn[j], 0.0);
    t_bot[j] = (-amax - c0) / dn[j];
    lip[j] = std::abs(dn[j]) + slope * std::hypot(da[j], db[j]);
    double step = (!s.waves.empty() && slope > 0)
                      ? (2 * std::numbers::pi / wmax) / 8 / std::max(std::hypot(da[j], db[j]), 1e-12)
                      : std::numeric_limits<double>::infinity();
    min_step[j] = std::min(step, (t_bot[j] - t_top) / 4);
    t[j] = lo[j] = t_top;
    act.push_back(j);
  }
  const std::size_t K = s.waves.size();
  std::vector<double> arg, sn, cs;
  // G(t) = c0 + t dn - h(a, b) and its derivative along the ray, for the rays in `idx` at their t.
  auto eval = [&](const std::vector<std::size_t>& idx) {
    const std::size_t na = idx.size();
    arg.resize(K * na);
    sn.resize(K * na);
    cs.resize(K * na);
    for (std::size_t q = 0; q < na; ++q) {
      const std::size_t j = idx[q];
      const double a = a0 + t[j] * da[j], b = b0 + t[j] * db[j];
      for (std::size_t k = 0; k < K; ++k) {
        const auto& w = s.waves[k];
        arg[k * na + q] = w[1] * (w[2] * a + w[3] * b) + w[4];
      }
    }
    detail::vec_sin(arg.data(), sn.data(), K * na);
    detail::vec_cos(arg.data(), cs.data(), K * na);
    for (std::size_t q = 0; q < na; ++q) {
      const std::size_t j = idx[q];
      double h = 0, ha = 0, hb = 0;
      for (std::size_t k = 0; k < K; ++k) {  // the waves in order, as Scene._height sums them
        const auto& w = s.waves[k];
        h += w[0] * sn[k * na + q];
        const double c = w[0] * w[1] * cs[k * na + q];
        ha += c * w[2];
        hb += c * w[3];
      }
      g[j] = c0 + t[j] * dn[j] - h;
      dg[j] = dn[j] - ha * da[j] - hb * db[j];
    }
  };
  // The march: bracket [lo, t] with G(lo) > 0 >= G(t) (t_bot always has G <= 0).
  for (int round = 0; round < 10'000 && !act.empty(); ++round) {
    eval(act);
    keep.clear();
    for (const std::size_t j : act) {
      if (g[j] <= 0 || t[j] >= t_bot[j]) {
        br_lo[j] = lo[j];
        br_hi[j] = std::min(t[j], t_bot[j]);
      } else {
        lo[j] = t[j];
        t[j] = std::min(t[j] + std::max(g[j] / lip[j], min_step[j]), t_bot[j]);
        keep.push_back(j);
      }
    }
    act.swap(keep);
  }
  // Newton inside the bracket, bisection otherwise, until the step is below 1e-15 t (80 rounds at most).
  act.clear();
  for (std::size_t j = 0; j < m; ++j) {
    if (!std::isfinite(br_lo[j])) continue;
    lo[j] = br_lo[j];
    hi[j] = br_hi[j];
    t[j] = out[j] = 0.5 * (lo[j] + hi[j]);
    act.push_back(j);
  }
  for (int round = 0; round < 80 && !act.empty(); ++round) {
    eval(act);
    keep.clear();
    for (const std::size_t j : act) {
      if (g[j] > 0)
        lo[j] = t[j];
      else
        hi[j] = t[j];
      const double tn = t[j] - g[j] / dg[j];
      const bool inside = std::isfinite(tn) && tn >= lo[j] && tn <= hi[j];
      const double t_new = inside ? tn : 0.5 * (lo[j] + hi[j]);
      const bool conv = std::abs(t_new - t[j]) <= 1e-15 * std::abs(t[j]) || hi[j] - lo[j] <= 1e-15 * std::abs(t[j]);
      out[j] = t_new;
      if (!conv) {
        t[j] = t_new;
        keep.push_back(j);
      }
    }
    act.swap(keep);
  }
}

// One ray; `t_heightfield` is its hit found by heightfield_hits (a heightfield only).
void trace_one(const TraceScene& s, double px, double py, std::size_t i, const TraceOut& o, double t_heightfield) {
  const V3 d = ray_direction(s, px, py);
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
    t = t_heightfield;
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
  if (!hit) {
    // uv and J are 0 off the surface: nothing to compute (the sphere's two atan2 are most of its cost).
    uv[0] = uv[1] = 0.0;
    J[0] = J[1] = J[2] = J[3] = 0.0;
  } else if (s.sphere) {
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
  const bool heightfield = !scene.sphere && !scene.waves.empty();
  detail::parallel_chunks(count, 2048, 8192, [&](std::size_t i0, std::size_t i1) {
    std::vector<double> t_hf(heightfield ? i1 - i0 : 0, kNaN);
    if (heightfield) heightfield_hits(scene, px + i0, py + i0, i1 - i0, t_hf.data());
    for (std::size_t i = i0; i < i1; ++i) trace_one(scene, px[i], py[i], i, out, heightfield ? t_hf[i - i0] : kNaN);
  });
}

}  // namespace glintlab::images
