// Lights as convex regions of directions and the exact reflection probability of a light by cubature
// (docs/math/lighting.md#lighting-probability, #lighting-cubature).
#include "glintlab/lighting/lighting.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "lighting_cubature.hpp"

namespace glintlab::lighting {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kNegligible = 1e-20;  // an absolute error that no count can see

Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double norm(Vec3 a) { return std::sqrt(dot(a, a)); }

Vec3 checked_unit(std::string_view where, std::string_view name, Vec3 v) {
  const double n = norm(v);
  if (!(n > 0) || !std::isfinite(n)) throw_invalid(where, name, n, "a finite non-zero vector (its length shown)");
  return (1.0 / n) * v;
}

// Two unit tangents completing the unit vector c to an orthonormal frame (Duff et al. 2017).
void tangents(Vec3 c, Vec3& e1, Vec3& e2) {
  const double s = std::copysign(1.0, c.z);
  const double a = -1.0 / (s + c.z), b = c.x * c.y * a;
  e1 = {1.0 + s * c.x * c.x * a, s * b, -s * c.x};
  e2 = {b, s + c.y * c.y * a, -c.y};
}

// The first rho in (0, pi] where A cos(rho) + B sin(rho) falls below t, given A >= t at rho = 0.
double exit_half_space(double A, double B, double t) {
  const double R = std::hypot(A, B);
  if (R <= t) return R < t ? 0.0 : std::atan2(B, A);
  const double e = std::atan2(B, A) + std::acos(std::clamp(t / R, -1.0, 1.0));
  return std::clamp(e, 0.0, kPi);
}

// The first rho in (0, pi] where a cos^2 + 2 b sin cos + e sin^2 reaches 0, given a < 0 (pi if never).
double exit_cone(double a, double b, double e) {
  const double m = 0.5 * (a + e), R = std::hypot(0.5 * (a - e), b);
  if (!(R > 0) || -m / R > 1.0 || -m / R < -1.0) return kPi;
  const double phi0 = std::atan2(b, 0.5 * (a - e)), beta = std::acos(-m / R);
  double best = 2 * kPi;
  for (double x : {phi0 + beta, phi0 - beta}) {
    while (x <= 0) x += 2 * kPi;
    while (x > 2 * kPi) x -= 2 * kPi;
    best = std::min(best, x);
  }
  return std::min(0.5 * best, kPi);
}

double quad_form(const double (&q)[3][3], Vec3 a, Vec3 b) {
  const double av[3] = {a.x, a.y, a.z}, bv[3] = {b.x, b.y, b.z};
  double s = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += av[i] * q[i][j] * bv[j];
  return s;
}

// Van Oosterom & Strackee (1983): the solid angle of the triangle (a, b, c) seen from the origin.
double triangle_solid_angle(Vec3 a, Vec3 b, Vec3 c) {
  const double la = norm(a), lb = norm(b), lc = norm(c);
  const double num = std::abs(dot(a, cross(b, c)));
  const double den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
  return 2.0 * std::atan2(num, den);
}

// The integral of f(w) over the light (above the horizon when `horizon`) in polar coordinates
// (rho, psi) about `pole`: w = cos(rho) pole + sin(rho) (cos(psi) e1 + sin(psi) e2), dw = sin(rho) drho dpsi.
// `peak`, `scale`: where the integrand may be peaked and how wide, for the breakpoints.
template <class F>
Integral integrate_light(const Light& light, Vec3 pole, Vec3 peak, double scale, F&& f, double rel_tol,
                         std::int64_t max_evaluations, bool horizon, double abs_floor) {
  Vec3 e1, e2;
  tangents(pole, e1, e2);
  const double psi_peak = std::atan2(dot(peak, e2), dot(peak, e1));
  const double dist = std::acos(std::clamp(dot(peak, pole), -1.0, 1.0));
  const double psi_scale = dist > scale ? scale / std::sin(std::min(dist, 0.5 * kPi)) : 0.0;
  auto outer_points = detail::geometric_points(psi_peak - kPi, psi_peak + kPi, psi_peak, psi_scale);
  // The boundary's corners seen from the pole: rho_max(psi) has kinks there, so they are breakpoints.
  for (const Vec3& corner : light.corners()) {
    double psi = std::atan2(dot(corner, e2), dot(corner, e1));
    if (psi < psi_peak - kPi) psi += 2 * kPi;
    if (psi > psi_peak + kPi) psi -= 2 * kPi;
    outer_points.push_back(psi);
  }
  std::sort(outer_points.begin(), outer_points.end());
  std::int64_t evaluations = 0;
  bool converged = true;
  const double inner_rel = rel_tol;
  const std::vector<double> inner_abs{abs_floor / (2 * kPi)};
  auto outer = [&](double psi, double* out) {
    const Vec3 d = std::cos(psi) * e1 + std::sin(psi) * e2;
    const double rho_max = light.exit(pole, d, horizon);
    const double rho_peak = std::atan2(dot(peak, d), dot(peak, pole));
    auto inner = [&](double rho, double* v) {
      const Vec3 w = std::cos(rho) * pole + std::sin(rho) * d;
      v[0] = f(w) * std::sin(rho);
    };
    const auto pts = detail::geometric_points(0.0, rho_max, std::max(rho_peak, 0.0), scale);
    const auto r = detail::adaptive_gk(inner, 1, pts, inner_rel, inner_abs, max_evaluations / 50);
    evaluations += r.evaluations;
    converged = converged && r.converged;
    out[0] = r.value[0];
  };
  const auto r = detail::adaptive_gk(outer, 1, outer_points, rel_tol, {abs_floor}, max_evaluations / 100);
  Integral result;
  result.value = r.value[0];
  result.error = r.error[0];
  result.evaluations = evaluations;
  result.converged = converged && r.converged && evaluations <= max_evaluations;
  return result;
}

void check_view(std::string_view where, Vec3 wo) {
  if (!(wo.z > 0) || !std::isfinite(wo.x) || !std::isfinite(wo.y) || !std::isfinite(wo.z))
    throw_invalid(where, "wo[2]", wo.z, "a finite view direction above the horizon (wo_z > 0)");
}

void check_alpha(std::string_view where, double alpha) {
  if (!(alpha > 0) || !std::isfinite(alpha)) throw_invalid(where, "alpha", alpha, "a finite number > 0");
}

// A pole inside the light and above the horizon: the mirror direction of the view when it lies in the
// light (the integrand's peak), else the light's centre.
Vec3 choose_pole(std::string_view where, const Light& light, Vec3 mirror) {
  if (light.contains(mirror)) return mirror;
  const Vec3 c = light.center();
  if (!(c.z > 1e-12)) throw_invalid(where, "light centre z", c.z, "a light whose centre is above the horizon (z > 0)");
  return c;
}

}  // namespace

Target parse_target(const std::string& name) {
  static constexpr std::array<std::pair<const char*, Target>, 2> kTable{
      {{"beckmann", Target::kBeckmann}, {"ggx", Target::kGgx}}};
  return parse_enum("lighting", "target", name, kTable);
}

double ndf_value(Target target, double alpha, double c) {
  if (!(c > 0)) return 0.0;
  const double a2 = alpha * alpha, c2 = c * c;
  if (target == Target::kBeckmann) {
    const double tan2 = (1.0 - c2) / c2;
    return std::exp(-tan2 / a2) / (kPi * a2 * c2 * c2);
  }
  const double d = (a2 - 1.0) * c2 + 1.0;
  return a2 / (kPi * d * d);
}

Light Light::cap(Vec3 direction, double half_angle) {
  if (!(half_angle > 0 && half_angle <= 0.5 * kPi))
    throw_invalid("lights.cap", "half_angle", half_angle, "an angle in (0, pi/2] radians");
  Light l;
  l.kind_ = Kind::kCap;
  l.center_ = checked_unit("lights.cap", "direction", direction);
  l.half_angle_ = half_angle;
  l.half_spaces_.push_back({l.center_, std::cos(half_angle)});
  return l;
}

Light Light::rect(Vec3 center, Vec3 edge_u, Vec3 edge_v) {
  const Vec3 n = cross(edge_u, edge_v);
  const double area = norm(n);
  if (!(area > 0) || !std::isfinite(area))
    throw_invalid("lights.rect", "edge_u x edge_v", area, "two finite, non-parallel edges (the area shown)");
  if (!(std::abs(dot(n, center)) > 1e-12 * area * norm(center)))
    throw_invalid("lights.rect", "center", norm(center),
                  "a rectangle whose plane does not pass through the shading point");
  Light l;
  l.kind_ = Kind::kRect;
  l.center_ = checked_unit("lights.rect", "center", center);
  l.corners_[0] = center - 0.5 * edge_u - 0.5 * edge_v;
  l.corners_[1] = center + 0.5 * edge_u - 0.5 * edge_v;
  l.corners_[2] = center + 0.5 * edge_u + 0.5 * edge_v;
  l.corners_[3] = center - 0.5 * edge_u + 0.5 * edge_v;
  for (int k = 0; k < 4; ++k) {
    Vec3 g = cross(l.corners_[k], l.corners_[(k + 1) % 4]);
    if (dot(g, center) < 0) g = -1.0 * g;
    l.half_spaces_.push_back({(1.0 / norm(g)) * g, 0.0});
  }
  return l;
}

Light Light::disk(Vec3 center, Vec3 normal, double radius) {
  if (!(radius > 0) || !std::isfinite(radius)) throw_invalid("lights.disk", "radius", radius, "a finite radius > 0");
  Vec3 n = checked_unit("lights.disk", "normal", normal);
  double h = dot(n, center);
  if (h < 0) n = -1.0 * n, h = -h;
  if (!(h > 1e-12 * norm(center)))
    throw_invalid("lights.disk", "center", norm(center), "a disk whose plane does not pass through the shading point");
  Light l;
  l.kind_ = Kind::kDisk;
  l.center_ = checked_unit("lights.disk", "center", center);
  l.half_angle_ = radius;
  // A w = h w - (n.w) center; inside: |A w|^2 <= r^2 (n.w)^2 on the front n.w > 0.
  const double nv[3] = {n.x, n.y, n.z}, cv[3] = {center.x, center.y, center.z};
  double A[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A[i][j] = (i == j ? h : 0.0) - cv[i] * nv[j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += A[k][i] * A[k][j];
      l.q_[i][j] = s - radius * radius * nv[i] * nv[j];
    }
  l.has_cone_ = true;
  l.front_ = n;
  l.half_spaces_.push_back({n, 0.0});
  return l;
}

bool Light::contains(Vec3 w) const {
  for (const auto& hs : half_spaces_)
    if (!(dot(w, hs.g) >= hs.t)) return false;
  return !has_cone_ || quad_form(q_, w, w) <= 0.0;
}

double Light::exit(Vec3 pole, Vec3 dir, bool horizon) const {
  double rho = kPi;
  for (const auto& hs : half_spaces_) rho = std::min(rho, exit_half_space(dot(pole, hs.g), dot(dir, hs.g), hs.t));
  if (has_cone_)
    rho = std::min(rho, exit_cone(quad_form(q_, pole, pole), quad_form(q_, pole, dir), quad_form(q_, dir, dir)));
  if (horizon) rho = std::min(rho, exit_half_space(pole.z, dir.z, 0.0));
  return rho;
}

double Light::solid_angle() const {
  if (kind_ == Kind::kCap) {  // 2 pi (1 - cos a), written without the cancellation of 1 - cos a for small a
    const double s = std::sin(0.5 * half_angle_);
    return 4 * kPi * s * s;
  }
  if (kind_ == Kind::kRect)
    return triangle_solid_angle(corners_[0], corners_[1], corners_[2]) +
           triangle_solid_angle(corners_[0], corners_[2], corners_[3]);
  auto one = [](Vec3) { return 1.0; };
  return integrate_light(*this, center_, center_, 0.0, one, 1e-12, 4000000, false, 0.0).value;
}

Light Light::in_frame(const Frame& frame) const {
  Light l = *this;
  l.center_ = frame.to_local(center_);
  for (auto& hs : l.half_spaces_) hs.g = frame.to_local(hs.g);
  for (auto& c : l.corners_) c = frame.to_local(c);
  l.front_ = frame.to_local(front_);
  // The disk's cone w^T Q w <= 0 in local directions w = R^T w_local (R's rows t, b, n): Q' = R Q R^T.
  const Vec3 rows[3] = {frame.t, frame.b, frame.n};
  double qr[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double rj[3] = {rows[j].x, rows[j].y, rows[j].z};
      qr[i][j] = q_[i][0] * rj[0] + q_[i][1] * rj[1] + q_[i][2] * rj[2];  // (Q R^T)[i][j]
    }
  for (int i = 0; i < 3; ++i) {
    const double ri[3] = {rows[i].x, rows[i].y, rows[i].z};
    for (int j = 0; j < 3; ++j) l.q_[i][j] = ri[0] * qr[0][j] + ri[1] * qr[1][j] + ri[2] * qr[2][j];
  }
  return l;
}

std::vector<Frame> frames_from(std::string_view where, std::string_view name, const std::vector<double>& values,
                               std::size_t count) {
  if (values.empty()) return {};
  check_length(where, name, values.size(), 9 * count);
  std::vector<Frame> out(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double* v = values.data() + 9 * i;
    const Frame f{{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, {v[6], v[7], v[8]}};
    const Vec3 axes[3] = {f.t, f.b, f.n};
    double worst = 0;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) worst = std::max(worst, std::abs(dot(axes[a], axes[b]) - (a == b ? 1.0 : 0.0)));
    if (!(worst <= 1e-6))
      throw_invalid(where, indexed_name(std::string(name), i, true), worst,
                    "an orthonormal frame (t, b, n) (its largest |t.b|, |t.t - 1|, ... shown)");
    out[i] = f;
  }
  return out;
}

std::string Light::describe() const {
  std::ostringstream s;
  s.precision(6);
  const char* names[] = {"cap", "rect", "disk"};
  s << "Light(" << names[static_cast<int>(kind_)] << ", centre=(" << center_.x << ", " << center_.y << ", " << center_.z
    << "), solid_angle=" << solid_angle() << ")";
  return s.str();
}

Integral reflection_probability(Target target, double alpha, Vec3 wo, const Light& light, double rel_tol,
                                std::int64_t max_evaluations) {
  check_alpha("reflection_probability", alpha);
  check_view("reflection_probability", wo);
  if (!(rel_tol > 0 && rel_tol < 1)) throw_invalid("reflection_probability", "rel_tol", rel_tol, "a number in (0, 1)");
  wo = (1.0 / norm(wo)) * wo;
  const Vec3 mirror{-wo.x, -wo.y, wo.z};
  const Vec3 pole = choose_pole("reflection_probability", light, mirror);
  auto f = [&](Vec3 w) {
    if (!(w.z > 0)) return 0.0;
    const Vec3 s = wo + w;
    const double len = norm(s);
    const double c = s.z / len, woh = dot(wo, s) / len;
    return ndf_value(target, alpha, c) * c / (4.0 * woh);
  };
  // The scale of the NDF's peak in light directions: the half vector turns by about half the light's
  // angle, so an NDF of width alpha in slope spans about alpha in wi; finer breakpoints only cost time.
  const double scale = std::min(alpha, 0.25);
  // A first pass at tolerance 1/2 (the breakpoints' pieces, hardly refined) gives the magnitude that sets the inner
  // integrals' absolute floor; below kNegligible a probability is 0 for any count (n p < 1e-5 at n = 1e15 facets).
  const Integral coarse = integrate_light(light, pole, mirror, scale, f, 0.5, max_evaluations, true, kNegligible);
  const double floor = std::max(kNegligible, 0.01 * rel_tol * std::abs(coarse.value));
  Integral r = integrate_light(light, pole, mirror, scale, f, rel_tol, max_evaluations, true, floor);
  r.evaluations += coarse.evaluations;
  return r;
}

Integral half_vector_solid_angle(Vec3 wo, const Light& light, double rel_tol) {
  check_view("half_vector_solid_angle", wo);
  wo = (1.0 / norm(wo)) * wo;
  const Vec3 pole = choose_pole("half_vector_solid_angle", light, light.center());
  auto f = [&](Vec3 w) {
    if (!(w.z > 0)) return 0.0;
    const Vec3 s = wo + w;
    return norm(s) / (4.0 * dot(wo, s));
  };
  return integrate_light(light, pole, pole, 0.0, f, rel_tol, 4000000, true, 0.0);
}

Integral visible_solid_angle(const Light& light, double rel_tol) {
  const Vec3 pole = choose_pole("visible_solid_angle", light, light.center());
  auto one = [](Vec3 w) { return w.z > 0 ? 1.0 : 0.0; };
  return integrate_light(light, pole, pole, 0.0, one, rel_tol, 4000000, true, 0.0);
}

std::pair<std::vector<double>, std::vector<double>> reflection_probabilities(Target target, double alpha,
                                                                             const std::vector<double>& wo,
                                                                             const Light& light, double rel_tol,
                                                                             const std::vector<Frame>& frames) {
  if (wo.size() % 3 != 0) check_length("reflection_probabilities", "wo", wo.size(), 3 * (wo.size() / 3 + 1));
  const std::size_t count = wo.size() / 3;
  if (!frames.empty()) check_length("reflection_probabilities", "frames", frames.size(), count);
  std::vector<double> values(count), errors(count);
  glintlab::detail::parallel_chunks(count, 16, 32, [&](std::size_t i0, std::size_t i1) {
    for (std::size_t i = i0; i < i1; ++i) {
      const Vec3 v{wo[3 * i], wo[3 * i + 1], wo[3 * i + 2]};
      const auto r = frames.empty() ? reflection_probability(target, alpha, v, light, rel_tol)
                                    : reflection_probability(target, alpha, v, light.in_frame(frames[i]), rel_tol);
      values[i] = r.value;
      errors[i] = r.error;
    }
  });
  return {values, errors};
}

}  // namespace glintlab::lighting
