// KPT25's disk integrals: the area of a rectangle inside the disk U and a Gaussian's mass there (the
// compensation of eq. 9, the exact expectations, Algorithm 2's block probabilities), and eq. 8's
// roulette (glinty_ndf.hpp, docs/math/glinty_ndf.md#glinty-algorithm1).
#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <vector>

#include "glintlab/glinty/glinty_ndf.hpp"
#include "kpt25_internal.hpp"

namespace glintlab {

using kpt25::kPi;
using kpt25::mass_1d;
using kpt25::normal_mass;

namespace {

// integral over X in [X0, X1] of min(c, s(X)), s(X) = sqrt(r^2 - X^2) the half chord of the disk of
// radius r = 1/2 centred at 0, for c >= 0 (rect_disk_area's building block).
double chord_part(double X0, double X1, double c) {
  constexpr double r = 0.5;
  X0 = std::max(X0, -r);
  X1 = std::min(X1, r);
  if (!(X1 > X0)) return 0.0;
  auto G = [](double X) {  // an antiderivative of s
    const double s = std::sqrt(std::max(0.0, r * r - X * X));
    return 0.5 * (X * s + r * r * std::asin(std::clamp(X / r, -1.0, 1.0)));
  };
  auto seg = [&](double a, double b, bool flat) {
    a = std::max(a, X0);
    b = std::min(b, X1);
    if (!(b > a)) return 0.0;
    return flat ? c * (b - a) : G(b) - G(a);
  };
  if (c >= r) return G(X1) - G(X0);
  const double xc = std::sqrt(r * r - c * c);  // |X| <= xc: s >= c
  return seg(-r, -xc, false) + seg(-xc, xc, true) + seg(xc, r, false);
}

}  // namespace

double rect_disk_area(double x0, double x1, double y0, double y1) {
  if (!(x1 > x0) || !(y1 > y0)) return 0.0;
  const double X0 = x0 - 0.5, X1 = x1 - 0.5, Y0 = y0 - 0.5, Y1 = y1 - 0.5;
  // The chord's length in [Y0, Y1] at X is min(Y1, s) - max(Y0, -s), clamped at 0; split by the signs of
  // Y0 and Y1 it is a difference or a sum of min(c, s) with c >= 0.
  if (Y0 >= 0.0) return chord_part(X0, X1, Y1) - chord_part(X0, X1, Y0);
  if (Y1 <= 0.0) return chord_part(X0, X1, -Y0) - chord_part(X0, X1, -Y1);
  return chord_part(X0, X1, Y1) + chord_part(X0, X1, -Y0);
}

double kpt25_roulette(double r, double w, double eps) {
  const double lo = std::max(0.0, r - eps), hi = std::min(1.0, r + eps);
  if (!(hi > lo)) return w >= r ? 1.0 : 0.0;  // eps = 0: the exact roulette (Heaviside)
  const double t = std::clamp((w - lo) / (hi - lo), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

double gaussian_in_disk_rect(double cx, double cy, double sigma, double x0, double x1, double y0, double y1) {
  // The Gaussian's mass beyond 12 sigma (about 1e-32) is below any use: clip the rectangle to it and to
  // the square.
  const double reach = 12.0 * sigma;
  x0 = std::max({x0, 0.0, cx - reach});
  x1 = std::min({x1, 1.0, cx + reach});
  y0 = std::max({y0, 0.0, cy - reach});
  y1 = std::min({y1, 1.0, cy + reach});
  if (!(x1 > x0) || !(y1 > y0)) return 0.0;
  // The clipped rectangle inside the disk (all four corners are), or the lobe so far inside the disk
  // that its mass beyond the rim, at most exp(-d^2 / (2 sigma^2)) for a rim d away, is below 3e-18:
  // the disk does not cut it, and the mass is a product of normal CDF differences (the common case).
  auto inside = [](double x, double y) { return (x - 0.5) * (x - 0.5) + (y - 0.5) * (y - 0.5) <= 0.25; };
  const double rim = 0.5 - std::hypot(cx - 0.5, cy - 0.5);
  if ((inside(x0, y0) && inside(x0, y1) && inside(x1, y0) && inside(x1, y1)) || rim > 9.0 * sigma)
    return mass_1d(cx, sigma, x0, x1) * mass_1d(cy, sigma, y0, y1);
  // Otherwise an integral over x of the Gaussian's mass on the chord in [y0, y1], in the variable
  // theta with x = (1 - cos theta) / 2: the half chord is sin(theta) / 2 and dx = sin(theta) / 2 dtheta,
  // so the square-root singularity of the chord at x = 0 and 1 disappears. The angle is measured from
  // the lobe's centre, theta = theta_c + tau, and the offsets x - cx and the chord's ends minus cy are
  // formed as a constant (computed once) plus sin(tau / 2) times a smooth factor: a lobe of std 1e-11
  // at the rim is then integrated without the rounding noise of forming x and subtracting cx, which
  // kept an adaptive rule from converging. The integrand is smooth between the angles where the
  // chord's end crosses y0 or y1 and the lobe's centre, which split the range. Globally adaptive
  // Gauss-Kronrod (31 points): the interval with the largest error estimate (|Kronrod - Gauss|, a
  // pessimistic bound: the result is far more accurate, about 1e-13 relative in the tests) is halved
  // until their sum is below 1e-7 of the total (or 1e-16 absolute), at most 60 times, so the cost is
  // bounded whatever sigma and the position.
  const double tc = std::acos(std::clamp(1.0 - 2.0 * cx, -1.0, 1.0));
  const double e0 = 0.5 * (1.0 - std::cos(tc)) - cx;  // x(theta_c) - cx: rounding only
  const double k_up = 0.5 + 0.5 * std::sin(tc) - cy, k_dn = 0.5 - 0.5 * std::sin(tc) - cy;
  const double t0 = std::acos(std::clamp(1.0 - 2.0 * x0, -1.0, 1.0)) - tc;
  const double t1 = std::acos(std::clamp(1.0 - 2.0 * x1, -1.0, 1.0)) - tc;
  double cuts[8];
  int nc = 0;
  cuts[nc++] = t0;
  cuts[nc++] = t1;
  for (double y : {y0, y1}) {
    const double d = 2.0 * std::abs(y - 0.5);
    if (d < 1.0) {
      const double t = std::asin(d);
      cuts[nc++] = t - tc;
      cuts[nc++] = kPi - t - tc;
    }
  }
  cuts[nc++] = 0.0;
  for (int i = 1; i < nc; ++i)  // insertion sort of at most 7 angles
    for (int j = i; j > 0 && cuts[j - 1] > cuts[j]; --j) std::swap(cuts[j - 1], cuts[j]);
  const double norm = 1.0 / (sigma * std::sqrt(2.0 * kPi));
  const double up = (y1 - cy) / sigma, dn = (y0 - cy) / sigma;
  auto f = [&](double tau) {
    const double half = std::sin(0.5 * tau), mid = tc + 0.5 * tau;
    const double s = 0.5 * std::sin(tc + tau);  // the half chord
    if (!(s > 0.0)) return 0.0;
    // cos(a) - cos(a + tau) = 2 sin(a + tau/2) sin(tau/2); sin(a + tau) - sin(a) = 2 cos(a + tau/2) sin(tau/2)
    const double z = (e0 + std::sin(mid) * half) / sigma;
    const double chord = std::cos(mid) * half;
    const double hi = std::min(up, (k_up + chord) / sigma), lo = std::max(dn, (k_dn - chord) / sigma);
    if (!(hi > lo)) return 0.0;
    return std::exp(-0.5 * z * z) * norm * normal_mass(lo, hi) * s;
  };
  struct Piece {
    double a, b, value, error;
  };
  using Gk = boost::math::quadrature::gauss_kronrod<double, 31>;
  auto rule = [&](double a, double b) {
    double err = 0.0;
    const double v = Gk::integrate(f, a, b, 0, 0.0, &err);
    return Piece{a, b, v, err};
  };
  auto by_error = [](const Piece& p, const Piece& q) { return p.error < q.error; };
  std::vector<Piece> heap;
  heap.reserve(64);
  double total = 0.0, error = 0.0;
  for (int c = 0; c + 1 < nc; ++c) {
    const double a = std::max(cuts[c], t0), b = std::min(cuts[c + 1], t1);
    if (!(b > a)) continue;
    heap.push_back(rule(a, b));
    total += heap.back().value;
    error += heap.back().error;
  }
  std::make_heap(heap.begin(), heap.end(), by_error);
  for (int it = 0; it < 60 && !heap.empty() && error > std::max(1e-7 * std::abs(total), 1e-16); ++it) {
    std::pop_heap(heap.begin(), heap.end(), by_error);
    const Piece p = heap.back();
    heap.pop_back();
    const double mid = 0.5 * (p.a + p.b);
    if (!(mid > p.a && mid < p.b)) break;  // no room left to split in double precision
    const Piece l = rule(p.a, mid), r = rule(mid, p.b);
    total += l.value + r.value - p.value;
    error += l.error + r.error - p.error;
    heap.push_back(l);
    std::push_heap(heap.begin(), heap.end(), by_error);
    heap.push_back(r);
    std::push_heap(heap.begin(), heap.end(), by_error);
  }
  return total;
}
}  // namespace glintlab
