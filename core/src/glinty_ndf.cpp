// KPT25's glinty NDF: point process, reference and Algorithm 1 (glinty_ndf.hpp, docs/math/glinty_ndf.md).
#include "glintlab/glinty_ndf.hpp"

#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/math/special_functions/erf.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "glintlab/errors.hpp"
#include "glintlab/rng.hpp"
#include "parallel.hpp"

namespace glintlab {

namespace {

constexpr char kWhere[] = "glinty_ndf kpt25";
constexpr double kPi = std::numbers::pi;
constexpr double kSqrt1_2 = 0.70710678118654752440;
// The spatial filter is a Gaussian truncated at Mahalanobis radius 3 and renormalised, so that the
// explicit sum and the reference enumerate the same finite set of cells and the filter still integrates
// to 1 (docs/math/glinty_ndf.md#glinty-filter). 1 - exp(-9/2) is the mass a 2D Gaussian keeps there.
constexpr double kFilterRadius = 3.0;
const double kFilterMass = -std::expm1(-0.5 * kFilterRadius * kFilterRadius);
// Angular cells farther than this many stds from T(h) contribute exp(-x^2/2) = 0 in double arithmetic
// (exp underflows to 0 below -745.2, and 39^2/2 = 760.5): skipping them keeps the reference an exact sum.
constexpr double kUnderflowRadius = kGlintUnderflowRadius;
// Random numbers of the points: a stream id of their own in the top byte of the last counter word, so
// they share nothing with the other users of a seed (rng.hpp keeps stream ids below 256 in the low
// 16 bits with the level above, a word below 2^24 for every level in use).
constexpr std::uint32_t kStreamGlintPoints = 8;

// Phi(b) - Phi(a) for a <= b without cancellation in either tail.
double normal_mass(double a, double b) {
  if (!(b > a)) return 0.0;
  // Shortcuts that return what the formulas below round to (Algorithm 2 asks for many masses of
  // narrow lobes, most of them 0 or 1): erfc(40 / sqrt 2) underflows to 0, and the tails beyond
  // 8.5 stds add up to less than half an ulp of 1.
  if (a > 40.0 || b < -40.0) return 0.0;
  if (a < -8.5 && b > 8.5) return 1.0;
  if (a >= 0.0) return 0.5 * (std::erfc(a * kSqrt1_2) - std::erfc(b * kSqrt1_2));
  if (b <= 0.0) return 0.5 * (std::erfc(-b * kSqrt1_2) - std::erfc(-a * kSqrt1_2));
  return 1.0 - 0.5 * (std::erfc(-a * kSqrt1_2) + std::erfc(b * kSqrt1_2));
}

// Mass of N(c, sigma^2) in [lo, hi].
double mass_1d(double c, double sigma, double lo, double hi) { return normal_mass((lo - c) / sigma, (hi - c) / sigma); }

// One Philox block of a point: counter (2 a + block, i, j, stream << 24 | level << 20 | tag << 16 | b),
// key = seed. a, b < 2^15 and level <= 15 fit (kGlintMaxLevel); tag < 4 selects the point process of a
// triplanar plane (0: the uv-mapped process, and every plane when they share one).
std::array<std::uint32_t, 4> point_block(std::uint64_t seed, int level, std::int64_t i, std::int64_t j, std::int64_t a,
                                         std::int64_t b, std::uint32_t block, std::uint32_t tag = 0) {
  const std::array<std::uint32_t, 4> counter = {static_cast<std::uint32_t>(2 * a) + block,
                                                static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j),
                                                (kStreamGlintPoints << 24) | (static_cast<std::uint32_t>(level) << 20) |
                                                    (tag << 16) | static_cast<std::uint32_t>(b)};
  return CounterRng::block(counter, {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)});
}

// 32 random bits to a uniform in (0, 1).
inline double unit(std::uint32_t w) { return (static_cast<double>(w) + 0.5) * 0x1.0p-32; }

// The cells [first, last] of one axis of B(k): the side x side block of cells whose centres are nearest
// to q (in cells), shifted to stay inside [0, n); the whole axis when n < side.
void block_range(double q, std::int64_t n, int side, std::int64_t& first, std::int64_t& last) {
  if (n <= side) {
    first = 0;
    last = n - 1;
    return;
  }
  first = static_cast<std::int64_t>(std::floor(q - 0.5 * (side - 1)));
  first = std::clamp<std::int64_t>(first, 0, n - side);
  last = first + side - 1;
}

// The draws of Algorithm 2: their own stream id and key (draw_seed), so they share nothing with the
// points' numbers (stream 8 in the top byte of the last counter word) or the other users of a seed.
constexpr std::uint16_t kStreamGlintDraw = 9;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// "uv[3, 0]": pixel i (of the flattened pixels), component c; the Python layer rewrites the pixel index
// as the multi-index of the caller's array.
std::string element(const char* name, std::size_t i, int c) {
  return std::string(name) + "[" + std::to_string(i) + ", " + std::to_string(c) + "]";
}
std::string row_name(const char* name, std::size_t i) { return std::string(name) + "[" + std::to_string(i) + ", :]"; }
// Ten significant digits: enough to recognise the caller's numbers (3.16, not 3.1600000000000001).
std::string short_value(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return buf;
}
std::string row_value(const double* x, int n) {
  std::string s = "[";
  for (int c = 0; c < n; ++c) s += (c ? ", " : "") + short_value(x[c]);
  return s + "]";
}

void check_uv(const double* uv, std::size_t i) {
  for (int c = 0; c < 2; ++c) {
    const double x = uv[2 * i + c];
    if (!std::isfinite(x) || std::abs(x) > 1e9)
      throw_invalid(kWhere, element("uv", i, c), x, "a finite position, |uv| <= 1e9");
  }
}

// A unit vector from any nonzero finite vector: scaled by its largest component first, so that neither
// 1e160 (whose squared length overflows) nor 1e-160 (whose squared length underflows) changes the
// result (docs/math/glinty_ndf.md#glinty-map). False for a zero vector.
bool unit_vector(const double* v, double out[3]) {
  const double s = std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
  if (!(s > 0.0)) return false;
  const double x = v[0] / s, y = v[1] / s, z = v[2] / s;
  const double len = std::sqrt(x * x + y * y + z * z);  // in [1, sqrt 3]
  out[0] = x / len;
  out[1] = y / len;
  out[2] = z / len;
  return true;
}

// A draw of N(g, s^2) truncated to [lo, hi] by inversion of its CDF; the tail the interval lies in is
// inverted through erfc so that intervals many stds from g keep their precision.
double truncated_normal(double g, double s, double lo, double hi, double u) {
  const double a = (lo - g) / s, b = (hi - g) / s;
  double z;
  if (a >= 0.0) {  // upper tail: Q(z) = erfc(z / sqrt 2) / 2 decreases
    const double qa = std::erfc(a * kSqrt1_2), qb = std::erfc(b * kSqrt1_2);
    const double q = qa - u * (qa - qb);
    z = q > 0.0 ? std::numbers::sqrt2 * boost::math::erfc_inv(q) : b;
  } else {  // 2 Phi(z) = erfc(-z / sqrt 2) increases
    const double pa = std::erfc(-a * kSqrt1_2), pb = std::erfc(-b * kSqrt1_2);
    const double q = pa + u * (pb - pa);
    z = q <= 0.0 ? a : (q >= 2.0 ? b : -std::numbers::sqrt2 * boost::math::erfc_inv(q));
  }
  return std::clamp(g + s * std::clamp(z, a, b), lo, hi);
}

// The x_a-region of the block whose first cell is f along one axis (block_range's inverse): x_a in
// [lo, hi) chooses it. The whole axis when the level has at most `side` cells.
void region_range(std::int64_t f, std::int64_t n, int side, double& lo, double& hi) {
  if (n <= side) {
    lo = 0.0;
    hi = 1.0;
    return;
  }
  const double fn = static_cast<double>(n), c = 0.5 * (side - 1);
  lo = f == 0 ? 0.0 : (static_cast<double>(f) + c) / fn;
  hi = f == n - side ? 1.0 : (static_cast<double>(f) + 1.0 + c) / fn;
}

// The first cells of every block of one axis that contains cell position q (in [0, 1)).
void blocks_containing(double q, std::int64_t n, int side, std::int64_t& f0, std::int64_t& f1) {
  if (n <= side) {
    f0 = f1 = 0;
    return;
  }
  const auto c = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor(q * static_cast<double>(n))), 0, n - 1);
  f0 = std::max<std::int64_t>(0, c - side + 1);
  f1 = std::min<std::int64_t>(c, n - side);
}

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

// Every point of level `level` whose position falls in the truncated filter and whose normal lies in U,
// restricted to angular cells [a0, a1] x [b0, b1]: f(a, b, mx, my, w) with w = R(r, w_l) exp(-q / 2),
// the point's filter weight up to the filter's normalisation (which cancels in Algorithm 2's ratios).
// The same cells, random numbers, rejection and roulette as level_sum (Algorithm 1).
template <class F>
void for_points(const Kpt25Params& p, double res, const GlintPixel& px, int level, double weight, double u, double v,
                std::uint64_t seed, std::int64_t a0, std::int64_t a1, std::int64_t b0, std::int64_t b1, F&& f) {
  const double cell = std::ldexp(1.0, level) / res;
  const double inv_na = std::ldexp(1.0, -level);
  const auto i0 = static_cast<std::int64_t>(std::floor((u - px.half_u) / cell));
  const auto i1 = static_cast<std::int64_t>(std::floor((u + px.half_u) / cell));
  const auto j0 = static_cast<std::int64_t>(std::floor((v - px.half_v) / cell));
  const auto j1 = static_cast<std::int64_t>(std::floor((v + px.half_v) / cell));
  const bool roulette = p.blend == GlintBlend::roulette && weight < 1.0;
  for (std::int64_t i = i0; i <= i1; ++i)
    for (std::int64_t j = j0; j <= j1; ++j)
      for (std::int64_t a = a0; a <= a1; ++a)
        for (std::int64_t b = b0; b <= b1; ++b) {
          const auto r4 = point_block(seed, level, i, j, a, b, 0);
          const double mx = (static_cast<double>(a) + unit(r4[2])) * inv_na;
          const double my = (static_cast<double>(b) + unit(r4[3])) * inv_na;
          if ((mx - 0.5) * (mx - 0.5) + (my - 0.5) * (my - 0.5) >= 0.25) continue;
          const double dx = (static_cast<double>(i) + unit(r4[0])) * cell - u;
          const double dy = (static_cast<double>(j) + unit(r4[1])) * cell - v;
          const double q = px.inv_a * dx * dx + 2.0 * px.inv_b * dx * dy + px.inv_c * dy * dy;
          if (q > kFilterRadius * kFilterRadius) continue;
          double keep = weight;
          if (roulette) keep = kpt25_roulette(unit(point_block(seed, level, i, j, a, b, 1)[0]), weight, p.epsilon);
          if (keep == 0.0) continue;
          f(a, b, mx, my, keep * std::exp(-0.5 * q), keep, q);
        }
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

Kpt25Ndf::Kpt25Ndf(const Kpt25Params& params) : p_(params) {
  if (!(p_.density > 0.0 && p_.density <= 1e18)) throw_invalid(kWhere, "density", p_.density, "a number in (0, 1e18]");
  if (!(p_.alpha > 0.0 && std::isfinite(p_.alpha))) throw_invalid(kWhere, "alpha", p_.alpha, "a finite number > 0");
  if (!(p_.alpha_star >= 1e-30 && std::isfinite(p_.alpha_star)))
    throw_invalid(kWhere, "alpha_star", p_.alpha_star, "a finite number >= 1e-30");
  if (!(p_.k == 1 || p_.k == 4 || p_.k == 9 || p_.k == 16))
    throw_invalid(kWhere, "k", static_cast<double>(p_.k), "1, 4, 9 or 16 (a square block of angular cells)");
  if (!(p_.epsilon >= 0.0 && p_.epsilon <= 0.5)) throw_invalid(kWhere, "epsilon", p_.epsilon, "a number in [0, 0.5]");
  if (!(p_.filter > 0.0 && std::isfinite(p_.filter)))
    throw_invalid(kWhere, "filter", p_.filter, "a finite pixel filter std > 0 (pixels)");
  if (!(p_.sample_smooth >= 0.0 && p_.sample_smooth <= 1.0))
    throw_invalid(kWhere, "sample_smooth", p_.sample_smooth, "a probability in [0, 1]");
  if (!(p_.alpha_y == 0.0 || (p_.alpha_y > 0.0 && std::isfinite(p_.alpha_y))))
    throw_invalid(kWhere, "alpha_y", p_.alpha_y, "a finite number > 0 (or 0: isotropic)");
  aniso_ = p_.alpha_y > 0.0 && p_.alpha_y != p_.alpha;
  for (double a : {p_.glint_ax, p_.glint_ay})
    if (!(a >= 1e-3 && a <= 1e3)) throw_invalid(kWhere, "anisotropy", a, "stretches in [1e-3, 1e3]");
  glint_aniso_ = !(p_.glint_ax == 1.0 && p_.glint_ay == 1.0);
  if (glint_aniso_ && p_.compensation == GlintCompensation::disk)
    throw_invalid(kWhere, "compensation", std::string("disk"), "\"square\" or \"none\" with anisotropic glints");
  if (!(p_.triplanar_sharpness > 0.0 && p_.triplanar_sharpness <= 64.0))
    throw_invalid(kWhere, "triplanar_sharpness", p_.triplanar_sharpness, "a number in (0, 64]");
  res_ = std::sqrt(p_.density);
  if (glint_aniso_)  // cells per unit of x_s = A_* uv
    res_ = p_.glint_printed_density ? std::sqrt(p_.density) / (p_.glint_ax * p_.glint_ay)
                                    : std::sqrt(p_.density / (p_.glint_ax * p_.glint_ay));
  // Line 19's 1 / K_P: the points per unit area of x_s (K_P / det A_*) when the uv density is preserved,
  // so that E = D(h); K_P as printed (then E = D(h) / det(A_*)^2 with the printed resolution).
  kp_ = p_.density;
  if (glint_aniso_ && !p_.glint_printed_density) kp_ = p_.density / (p_.glint_ax * p_.glint_ay);
}

void Kpt25Ndf::refuse_glint_anisotropy(const char* what) const {
  if (glint_aniso_)
    throw_invalid(kWhere, "anisotropy", "(" + short_value(p_.glint_ax) + ", " + short_value(p_.glint_ay) + ")",
                  std::string("(1, 1) for ") + what + " (anisotropic glints: evaluate and reference only)");
}

// Anisotropic roughness: the stretch M = diag(1 / ax, 1 / ay, 1) of eq. 6 applied to the slopes
// (Beckmann) or to the half vector (GGX); the same constructions as the isotropic map below.
std::array<double, 3> Kpt25Ndf::map_aniso(const double h[3]) const {
  const double ax = p_.alpha, ay = p_.alpha_y, hx = h[0], hy = h[1], hz = h[2];
  double dx, dy, D;
  if (p_.target == GlintTarget::beckmann) {
    // Stretched slopes (s_x / ax, s_y / ay) are Gaussian with the isotropic law of alpha = 1; D =
    // exp(-t) / (pi ax ay cos^4), t = |stretched slope|^2.
    const double sx = hx / hz / ax, sy = hy / hz / ay, t = sx * sx + sy * sy;
    const double s2 = (hx * hx + hy * hy) / (hz * hz);
    if (!(t < 800.0)) {
      const double r = std::sqrt(sx * sx + sy * sy);
      return {0.5 + 0.5 * sx / r, 0.5 + 0.5 * sy / r, 0.0};
    }
    const double scale = t > 1e-300 ? std::sqrt(-std::expm1(-t) / t) : 1.0;
    dx = sx * scale;
    dy = sy * scale;
    D = std::exp(-t + 2.0 * std::log1p(s2)) / (kPi * ax * ay);
  } else {
    // GGX: D = 1 / (pi ax ay (hx^2 / ax^2 + hy^2 / ay^2 + hz^2)^2), the stretched normal cosine distributed.
    const double px = hx / ax, py = hy / ay, n2 = px * px + py * py + hz * hz, n = std::sqrt(n2);
    dx = px / n;
    dy = py / n;
    if (p_.ggx_lambert) {
      const double l = 1.0 / std::sqrt(1.0 + hz / n);
      dx *= l;
      dy *= l;
    }
    D = 1.0 / (kPi * ax * ay * n2 * n2);
  }
  return {0.5 + 0.5 * dx, 0.5 + 0.5 * dy, D};
}

std::array<double, 3> Kpt25Ndf::inverse_map_aniso(double dx, double dy, double r2) const {
  const double ax = p_.alpha, ay = p_.alpha_y;
  double v[3];
  if (p_.target == GlintTarget::beckmann) {
    const double ratio = r2 > 1e-300 ? std::sqrt(-std::log1p(-r2) / r2) : 1.0;
    v[0] = ax * dx * ratio;
    v[1] = ay * dy * ratio;
    v[2] = 1.0;
  } else if (p_.ggx_lambert) {
    const double l = std::sqrt(2.0 - r2);
    v[0] = ax * dx * l;
    v[1] = ay * dy * l;
    v[2] = 1.0 - r2;
  } else {
    v[0] = ax * dx;
    v[1] = ay * dy;
    v[2] = std::sqrt(std::max(0.0, 1.0 - r2));
  }
  double h[3];
  if (!unit_vector(v, h)) return {kNaN, kNaN, kNaN};
  return {h[0], h[1], h[2]};
}

double Kpt25Ndf::disk_D_aniso(double dx, double dy, double r2) const {
  const double ax = p_.alpha, ay = p_.alpha_y;
  if (p_.target == GlintTarget::beckmann) {
    // |s|^2 = (t / r2)(ax^2 dx^2 + ay^2 dy^2), t = -log(1 - r2); D = (1 - r2)(1 + |s|^2)^2 / (pi ax ay).
    const double t_r2 = r2 > 1e-300 ? -std::log1p(-r2) / r2 : 1.0;
    const double g = 1.0 + t_r2 * (ax * ax * dx * dx + ay * ay * dy * dy);
    return (1.0 - r2) * g * g / (kPi * ax * ay);
  }
  // The unstretched v = (ax w_x, ay w_y, w_z) of the unit stretched normal w: D = |v|^4 / (pi ax ay).
  double wx = dx, wy = dy, wz = std::sqrt(std::max(0.0, 1.0 - r2));
  if (p_.ggx_lambert) {
    const double l = std::sqrt(2.0 - r2);
    wx *= l;
    wy *= l;
    wz = 1.0 - r2;
  }
  const double v2 = ax * ax * wx * wx + ay * ay * wy * wy + wz * wz;
  return v2 * v2 / (kPi * ax * ay);
}

std::array<double, 3> Kpt25Ndf::map(const double hin[3]) const {
  double h[3];
  if (!unit_vector(hin, h) || !(h[2] > 0.0)) return {0.5, 0.5, 0.0};  // below the horizon: D = 0
  if (aniso_) return map_aniso(h);
  const double hx = h[0], hy = h[1], hz = h[2];
  const double a2 = p_.alpha * p_.alpha;
  double dx, dy, D;
  if (p_.target == GlintTarget::beckmann) {
    // Slopes s = (hx, hy) / hz are Gaussian (variance alpha^2 / 2 per axis) under D(h)(h.n)dh, so
    // |d|^2 = 1 - exp(-|s|^2 / alpha^2) is uniform and d = s |d| / |s| is uniform on the unit disk
    // (the inverse of §3.2.2's B1, Marsaglia's polar map). -expm1(-t)/t stays accurate as t -> 0.
    const double r2 = hx * hx + hy * hy;
    const double s2 = r2 / (hz * hz), t = s2 / a2;
    if (!(t < 800.0)) {
      // exp(-t) underflows: D = 0 and T(h) is on the rim, in the direction of (hx, hy) (the limit as
      // h_z -> 0; computing it through the slopes would give 0 x inf = NaN, or overflow).
      const double r = std::sqrt(r2);
      return {0.5 + 0.5 * hx / r, 0.5 + 0.5 * hy / r, 0.0};
    }
    const double scale = t > 1e-300 ? std::sqrt(-std::expm1(-t) / t) / p_.alpha : 1.0 / p_.alpha;
    dx = hx / hz * scale;
    dy = hy / hz * scale;
    // D = exp(-t) / (pi alpha^2 cos^4) with 1 / cos^4 = (1 + s^2)^2, in logs so that neither factor
    // overflows at grazing h.
    D = std::exp(-t + 2.0 * std::log1p(s2)) / (kPi * a2);
  } else {
    // GGX: the stretched half vector (hx / alpha, hy / alpha, hz), normalised, is cosine distributed
    // under D(h)(h.n)dh (§3.2.1's M~ with M = diag(1/alpha, 1/alpha, 1)); its orthographic projection
    // (x, y) is then uniform on the unit disk (docs/math/glinty_ndf.md#glinty-map: not the Lambert
    // projection of eq. 7, which makes a uniform hemisphere uniform, not a cosine-weighted one).
    const double px = hx / p_.alpha, py = hy / p_.alpha;
    const double n = std::sqrt(px * px + py * py + hz * hz);
    dx = px / n;
    dy = py / n;
    if (p_.ggx_lambert) {
      // Eq. 7: L(x, y, z) = (x, y) / sqrt(1 + z), |L|^2 = 1 - z on the unit hemisphere (equal-area).
      const double l = 1.0 / std::sqrt(1.0 + hz / n);
      dx *= l;
      dy *= l;
    }
    const double q = (a2 - 1.0) * hz * hz + 1.0;
    D = a2 / (kPi * q * q);
  }
  return {0.5 + 0.5 * dx, 0.5 + 0.5 * dy, D};
}

std::array<double, 3> Kpt25Ndf::inverse_map(double x, double y) const {
  const double dx = 2.0 * x - 1.0, dy = 2.0 * y - 1.0, r2 = dx * dx + dy * dy;
  if (!(r2 < 1.0)) return {kNaN, kNaN, kNaN};
  if (aniso_) return inverse_map_aniso(dx, dy, r2);
  double v[3];
  if (p_.target == GlintTarget::beckmann) {
    // |s|^2 = alpha^2 t with t = -log(1 - |d|^2) (the map above, inverted); t / |d|^2 -> 1 as d -> 0.
    const double ratio = r2 > 1e-300 ? std::sqrt(-std::log1p(-r2) / r2) : 1.0;
    v[0] = p_.alpha * dx * ratio;
    v[1] = p_.alpha * dy * ratio;
    v[2] = 1.0;
  } else if (p_.ggx_lambert) {  // L^-1: z = 1 - |d|^2, (x, y) = d sqrt(1 + z); then unstretched
    const double l = std::sqrt(2.0 - r2);
    v[0] = p_.alpha * dx * l;
    v[1] = p_.alpha * dy * l;
    v[2] = 1.0 - r2;
  } else {  // the stretched normal (dx, dy, sqrt(1 - |d|^2)), unstretched
    v[0] = p_.alpha * dx;
    v[1] = p_.alpha * dy;
    v[2] = std::sqrt(std::max(0.0, 1.0 - r2));
  }
  double h[3];
  if (!unit_vector(v, h)) return {kNaN, kNaN, kNaN};
  return {h[0], h[1], h[2]};
}

double Kpt25Ndf::disk_D(double x, double y) const {
  // D(T^-1(x, y)) without forming h: with r2 = |d|^2, Beckmann D = (1 - r2)(1 + alpha^2 t)^2 / (pi alpha^2),
  // t = -log(1 - r2); GGX D = (alpha^2 r2 + 1 - r2)^2 / (pi alpha^2).
  const double dx = 2.0 * x - 1.0, dy = 2.0 * y - 1.0, r2 = dx * dx + dy * dy;
  const double a2 = p_.alpha * p_.alpha;
  if (!(r2 < 1.0)) return 0.0;
  if (aniso_) return disk_D_aniso(dx, dy, r2);
  if (p_.target == GlintTarget::beckmann) {
    const double g = 1.0 - a2 * std::log1p(-r2);
    return (1.0 - r2) * g * g / (kPi * a2);
  }
  if (p_.ggx_lambert) {
    // The stretched normal has z = 1 - r2 and |(x, y)|^2 = 1 - z^2 = r2 (2 - r2); GGX D at its
    // unstretched h is (alpha^2 |(x, y)|^2 + z^2)^2 / (pi alpha^2).
    const double z = 1.0 - r2;
    const double g = a2 * r2 * (2.0 - r2) + z * z;
    return g * g / (kPi * a2);
  }
  const double g = a2 * r2 + 1.0 - r2;
  return g * g / (kPi * a2);
}

double Kpt25Ndf::jacobian(double D, double hz) const {
  if (p_.target == GlintTarget::ggx && p_.ggx_lambert) return 0.125 * kPi * D;
  return 0.25 * kPi * D * hz;
}

void Kpt25Ndf::map_points(const double* h, std::size_t m, double* xy) const {
  detail::parallel_chunks(m, 256, 512, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double* H = h + 3 * i;
      double u[3];
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(H[c])) throw_invalid(kWhere, element("h", i, c), H[c], "a finite half vector");
      if (!unit_vector(H, u)) throw_invalid(kWhere, row_name("h", i), row_value(H, 3), "a nonzero half vector");
      if (!(u[2] > 0.0)) {
        xy[2 * i] = xy[2 * i + 1] = kNaN;  // below the horizon: T is not defined
        continue;
      }
      const auto t = map(H);
      xy[2 * i] = t[0];
      xy[2 * i + 1] = t[1];
    }
  });
}

void Kpt25Ndf::footprint(GlintPixel& px, const double* jac, std::size_t i) const {
  px.index = i;
  const double* J = jac + 4 * i;
  px.J = J;
  for (int c = 0; c < 4; ++c)
    if (!std::isfinite(J[c]) || std::abs(J[c]) > 1e12)
      throw_invalid(kWhere, element("J", i, c), J[c], "a finite derivative, |J| <= 1e12");
  double Js[4];
  if (glint_aniso_) {  // the footprint of x_s = A_* uv (Algorithm 1, line 2)
    Js[0] = p_.glint_ax * J[0];
    Js[1] = p_.glint_ay * J[1];
    Js[2] = p_.glint_ax * J[2];
    Js[3] = p_.glint_ay * J[3];
    J = Js;
  }
  // Spatial covariance f^2 J J^T (Algorithm 1, line 11) with J = [[du/dx, du/dy], [dv/dx, dv/dy]].
  const double f2 = p_.filter * p_.filter;
  const double suu = f2 * (J[0] * J[0] + J[2] * J[2]), svv = f2 * (J[1] * J[1] + J[3] * J[3]);
  const double suv = f2 * (J[0] * J[1] + J[2] * J[3]);
  const double detj = J[0] * J[3] - J[1] * J[2];
  const double det = f2 * f2 * detj * detj;
  if (!(det > 0.0) || !(det > 1e-24 * suu * svv))
    throw_invalid(kWhere, row_name("J", i), row_value(J, 4),
                  "a footprint with det J != 0 (here " + short_value(detj) +
                      ") and anisotropy below 1e12 (mask pixels that do not see the surface)");
  px.inv_a = svv / det;
  px.inv_b = -suv / det;
  px.inv_c = suu / det;
  px.norm = 1.0 / (2.0 * kPi * std::sqrt(det) * kFilterMass);
  px.half_u = kFilterRadius * std::sqrt(suu);
  px.half_v = kFilterRadius * std::sqrt(svv);
  // The level at which the filter's box (side 2 x 3 sigma_major) equals one cell (§3.3.2: the footprint
  // fits between once and twice the cell size): at most 3 x 3 cells at floor(lambda), 2 x 2 above.
  const double tr = suu + svv, disc = std::sqrt(std::max(0.0, 0.25 * (suu - svv) * (suu - svv) + suv * suv));
  const double major = std::sqrt(0.5 * tr + disc);
  px.lambda = std::log2(res_ * 2.0 * kFilterRadius * major);
  if (!(px.lambda <= kGlintMaxLevel))
    throw_invalid(kWhere, row_name("J", i), row_value(J, 4),
                  "a footprint small enough for the density (MIP level " + short_value(px.lambda) + " > " +
                      std::to_string(kGlintMaxLevel) + "; lower the density or the footprint)");
  px.lambda = std::max(0.0, px.lambda);
  const int l0 = static_cast<int>(std::floor(px.lambda));
  const double frac = px.lambda - l0;
  px.levels[0] = l0;
  if (frac > 0.0 && l0 < kGlintMaxLevel) {
    px.n_levels = 2;
    px.levels[1] = l0 + 1;
    px.weights[0] = 1.0 - frac;  // w_l = 1 - |lambda - l| (Algorithm 1, line 8)
    px.weights[1] = frac;
  }
}

GlintPixel Kpt25Ndf::pixel(const double* jac, const double* h, std::size_t i) const {
  GlintPixel px;
  const double* H = h + 3 * i;
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(H[c])) throw_invalid(kWhere, element("h", i, c), H[c], "a finite half vector");
  double unit_h[3];
  if (!unit_vector(H, unit_h)) throw_invalid(kWhere, row_name("h", i), row_value(H, 3), "a nonzero half vector");
  footprint(px, jac, i);
  const auto m = map(H);
  px.xa = m[0];
  px.ya = m[1];
  px.D = m[2];
  px.sigma = p_.alpha_star * std::sqrt(px.D);
  px.sigma_y = px.sigma;
  if (glint_aniso_) {  // Sigma_a = d (alpha_star A_*^-1)^2 (Algorithm 1, line 12)
    px.sigma_y = px.sigma / p_.glint_ay;
    px.sigma = px.sigma / p_.glint_ax;
    if (!(px.sigma_y * px.sigma_y > 1e-300)) px.D = 0.0;
  }
  // Where sigma^2 underflows (D(h) < 1e-240 at alpha_star >= 1e-30: the far grazing tail of Beckmann)
  // the lobes' 1 / (2 pi sigma^2) would give 0 x inf; the value D(h) x (a mass <= 1) is below 1e-240
  // there, and is returned as 0, the limit at grazing (docs/math/glinty_ndf.md#glinty-map).
  if (!(px.sigma * px.sigma > 1e-300)) px.D = 0.0;
  return px;
}

double Kpt25Ndf::level_sum(const GlintPixel& px, int level, double weight, double u, double v, std::uint64_t seed,
                           bool all_angular, double* points, const double* palette, int n_colors, double* rgb,
                           double plane_weight, std::uint32_t tag, double* kept) const {
  if (glint_aniso_) {  // x_s = A_* uv (Algorithm 1, line 2)
    u *= p_.glint_ax;
    v *= p_.glint_ay;
  }
  const double cell = std::ldexp(1.0, level) / res_;  // spatial cell side at this level
  const std::int64_t na = std::int64_t{1} << level;   // angular cells per axis
  const double fna = static_cast<double>(na);
  const auto i0 = static_cast<std::int64_t>(std::floor((u - px.half_u) / cell));
  const auto i1 = static_cast<std::int64_t>(std::floor((u + px.half_u) / cell));
  const auto j0 = static_cast<std::int64_t>(std::floor((v - px.half_v) / cell));
  const auto j1 = static_cast<std::int64_t>(std::floor((v + px.half_v) / cell));
  std::int64_t a0, a1, b0, b1;
  if (all_angular) {
    const double reach = px.reach * px.sigma, reach_y = px.reach * px.sigma_y;
    a0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((px.xa - reach) * fna)));
    a1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((px.xa + reach) * fna)));
    b0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((px.ya - reach_y) * fna)));
    b1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((px.ya + reach_y) * fna)));
    const double cells = static_cast<double>(i1 - i0 + 1) * static_cast<double>(j1 - j0 + 1) *
                         static_cast<double>(std::max<std::int64_t>(0, a1 - a0 + 1)) *
                         static_cast<double>(std::max<std::int64_t>(0, b1 - b0 + 1));
    if (cells > kGlintMaxReferenceCells)
      throw_invalid(kWhere, row_name("J", px.index), row_value(px.J, 4),
                    "a footprint whose reference sums at most 2e8 cells (this one: " + format_value(cells) +
                        " at level " + std::to_string(level) + "; lower the density or the footprint)");
  } else {
    const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
    block_range(px.xa * fna, na, side, a0, a1);
    block_range(px.ya * fna, na, side, b0, b1);
  }
  const double inv_na = 1.0 / static_cast<double>(na);
  const double inv2s2 = 0.5 / (px.sigma * px.sigma);
  const double inv2sx = inv2s2, inv2sy = 0.5 / (px.sigma_y * px.sigma_y);  // anisotropic glints
  const bool roulette = p_.blend == GlintBlend::roulette && weight < 1.0;
  // A triplanar plane's weight: a second roulette on a random number of the point's own (the third word
  // of its roulette block), independent of the level's, so the keep rates multiply (or w_i itself with
  // the linear blend).
  const bool plane_roulette = plane_weight < 1.0 && p_.blend == GlintBlend::roulette;
  double sum = 0.0, count = 0.0, kept_sum = 0.0, rgb_raw[3] = {0.0, 0.0, 0.0};
  for (std::int64_t i = i0; i <= i1; ++i) {
    for (std::int64_t j = j0; j <= j1; ++j) {
      for (std::int64_t a = a0; a <= a1; ++a) {
        for (std::int64_t b = b0; b <= b1; ++b) {
          const auto r4 = point_block(seed, level, i, j, a, b, 0, tag);
          // Normal-space coordinates in the unit square; points outside the disk U are rejected (§3.3.1).
          const double mx = (static_cast<double>(a) + unit(r4[2])) * inv_na;
          const double my = (static_cast<double>(b) + unit(r4[3])) * inv_na;
          if ((mx - 0.5) * (mx - 0.5) + (my - 0.5) * (my - 0.5) >= 0.25) continue;
          const double dx = (static_cast<double>(i) + unit(r4[0])) * cell - u;
          const double dy = (static_cast<double>(j) + unit(r4[1])) * cell - v;
          const double q = px.inv_a * dx * dx + 2.0 * px.inv_b * dx * dy + px.inv_c * dy * dy;
          if (q > kFilterRadius * kFilterRadius) continue;
          count += 1.0;
          double keep = weight;  // linear blend, or a level of weight 1
          if (roulette || plane_roulette) {
            const auto r1 = point_block(seed, level, i, j, a, b, 1, tag);
            if (roulette) keep = kpt25_roulette(unit(r1[0]), weight, p_.epsilon);
            if (plane_roulette) keep *= kpt25_roulette(unit(r1[2]), plane_weight, p_.epsilon);
          } else if (plane_weight < 1.0) {
            keep *= plane_weight;
          }
          if (keep == 0.0) continue;
          kept_sum += keep;
          const double ex = mx - px.xa, ey = my - px.ya;
          const double term = glint_aniso_ ? keep * px.norm * std::exp(-0.5 * q - ex * ex * inv2sx - ey * ey * inv2sy)
                                           : keep * px.norm * std::exp(-0.5 * q - (ex * ex + ey * ey) * inv2s2);
          sum += term;
          if (rgb) {  // GlintColor(i_s, i_a, l): the second word of the point's roulette block
            const double cu = unit(point_block(seed, level, i, j, a, b, 1, tag)[1]);
            const int idx = std::min(n_colors - 1, static_cast<int>(cu * n_colors));
            for (int c = 0; c < 3; ++c) rgb_raw[c] += term * palette[3 * idx + c];
          }
        }
      }
    }
  }
  if (points) *points += count;
  if (kept) *kept += kept_sum;
  // The angular Gaussian's normalisation 1 / (2 pi sigma^2) (a 2D density: eq. 4 prints the 1D one);
  // 1 / (2 pi sigma_x sigma_y) with anisotropic glints.
  const double norm_a = glint_aniso_ ? 2.0 * kPi * px.sigma * px.sigma_y : 2.0 * kPi * px.sigma * px.sigma;
  if (rgb)
    for (int c = 0; c < 3; ++c) rgb[c] += rgb_raw[c] / norm_a;
  return sum / norm_a;
}

double Kpt25Ndf::compensation(const GlintPixel& px, int level) const {
  if (p_.compensation == GlintCompensation::none) return 0.0;
  const std::int64_t na = std::int64_t{1} << level;
  const double fna = static_cast<double>(na);
  const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
  std::int64_t a0, a1, b0, b1;
  block_range(px.xa * fna, na, side, a0, a1);
  block_range(px.ya * fna, na, side, b0, b1);
  const double inv = 1.0 / static_cast<double>(na);
  const double bx0 = static_cast<double>(a0) * inv, bx1 = static_cast<double>(a1 + 1) * inv;
  const double by0 = static_cast<double>(b0) * inv, by1 = static_cast<double>(b1 + 1) * inv;
  const double s = px.sigma;
  if (p_.compensation == GlintCompensation::disk) {  // eq. 9: U minus B(k)
    return gaussian_in_disk_rect(px.xa, px.ya, s, 0.0, 1.0, 0.0, 1.0) -
           gaussian_in_disk_rect(px.xa, px.ya, s, bx0, bx1, by0, by1);
  }
  // eq. 10: the unit square minus its part in B(k), products of 1D normal masses.
  const double sy = px.sigma_y;  // = s but with anisotropic glints
  const double square = mass_1d(px.xa, s, 0.0, 1.0) * mass_1d(px.ya, sy, 0.0, 1.0);
  const double in_b = mass_1d(px.xa, s, bx0, bx1) * mass_1d(px.ya, sy, by0, by1);
  return p_.compensation == GlintCompensation::square_flipped ? square + in_b : square - in_b;
}

void Kpt25Ndf::evaluate(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                        double* out) const {
  detail::parallel_chunks(m, 64, 128, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double u = uv[2 * i], v = uv[2 * i + 1];
      check_uv(uv, i);
      const GlintPixel px = pixel(jac, h, i);
      if (px.D == 0.0) {
        out[i] = 0.0;
        continue;
      }
      double explicit_sum = 0.0, comp = 0.0;
      for (int l = 0; l < px.n_levels; ++l) {
        explicit_sum += level_sum(px, px.levels[l], px.weights[l], u, v, seed, false, nullptr);
        comp += px.weights[l] * compensation(px, px.levels[l]);  // blended linearly (Fig. 5)
      }
      out[i] = px.D * (explicit_sum / kp_ + comp);  // eq. 11 with |J_T| read as D(h)
    }
  });
}

namespace {

// The reach (in lobe stds) of a reference with tolerance tol: a skipped cell lies more than r stds from
// T(h) along x or y, so each of its points' terms is below exp(-r^2 / 2) times its filter weight (keep x
// norm x exp(-q / 2)) over 2 pi sigma_x sigma_y; with exp(-r^2 / 2) / (2 pi sigma_x sigma_y) = tol the
// skipped terms add up to at most tol x the pixel's filter weight W summed over every point, i.e. the value
// D (sum) / K_P moves by at most tol x D(h) x W / K_P (docs/math/glinty_ndf.md#glinty-reference-reach).
// Never above the underflow radius, where the sum is already exact.
double reference_reach(const GlintPixel& px, double tol) {
  if (!(tol > 0.0)) return kUnderflowRadius;
  const double r2 = -2.0 * std::log(tol * 2.0 * kPi * px.sigma * px.sigma_y);
  return r2 > 0.0 ? std::min(kUnderflowRadius, std::sqrt(r2)) : 0.0;
}

}  // namespace

void Kpt25Ndf::reference(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                         double* out, double* out_points, double tol) const {
  if (!(tol >= 0.0 && tol < 1.0)) throw_invalid(kWhere, "tol", tol, "a tolerance in [0, 1) (0: the exact sum)");
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double u = uv[2 * i], v = uv[2 * i + 1];
      check_uv(uv, i);
      GlintPixel px = pixel(jac, h, i);
      px.reach = reference_reach(px, tol);
      double points = 0.0, sum = 0.0;
      if (px.D > 0.0)
        for (int l = 0; l < px.n_levels; ++l)
          sum += level_sum(px, px.levels[l], px.weights[l], u, v, seed, true, &points);
      out[i] = px.D * sum / kp_;
      if (out_points) out_points[i] = points;
    }
  });
}

double Kpt25Ndf::keep_rate(double w) const {
  // E over r of R(r, w): w for the linear blend and in the interior of the roulette; by quadrature at
  // the ends, where the clamps of eq. 8 make it differ from w (rho(w) + rho(1 - w) = 1 still holds).
  if (p_.blend == GlintBlend::linear || w >= 1.0 || w <= 0.0) return std::clamp(w, 0.0, 1.0);
  if (p_.epsilon == 0.0) return w;
  auto f = [&](double r) { return kpt25_roulette(r, w, p_.epsilon); };
  double total = 0.0;
  double cuts[] = {0.0,
                   std::clamp(w - p_.epsilon, 0.0, 1.0),
                   std::clamp(w + p_.epsilon, 0.0, 1.0),
                   std::min(p_.epsilon, 1.0),
                   std::max(0.0, 1.0 - p_.epsilon),
                   1.0};
  std::sort(std::begin(cuts), std::end(cuts));
  for (int c = 0; c + 1 < 6; ++c)
    if (cuts[c + 1] > cuts[c])
      total += boost::math::quadrature::gauss_kronrod<double, 15>::integrate(f, cuts[c], cuts[c + 1], 10, 1e-13);
  return total;
}

double Kpt25Ndf::expected_alg(const GlintPixel& px, double plane_rho, double plane_w) const {
  double total = 0.0;
  const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
  for (int l = 0; l < px.n_levels; ++l) {
    const std::int64_t na = std::int64_t{1} << px.levels[l];
    const double fna = static_cast<double>(na);
    std::int64_t a0, a1, b0, b1;
    block_range(px.xa * fna, na, side, a0, a1);
    block_range(px.ya * fna, na, side, b0, b1);
    const double inv = 1.0 / static_cast<double>(na);
    const double in_b =
        gaussian_in_disk_rect(px.xa, px.ya, px.sigma, static_cast<double>(a0) * inv, static_cast<double>(a1 + 1) * inv,
                              static_cast<double>(b0) * inv, static_cast<double>(b1 + 1) * inv);
    total += keep_rate(px.weights[l]) * plane_rho * in_b + px.weights[l] * plane_w * compensation(px, px.levels[l]);
  }
  return total;
}

void Kpt25Ndf::expected(const double* jac, const double* h, std::size_t m, double* e_ref, double* e_alg) const {
  refuse_glint_anisotropy("expected");
  detail::parallel_chunks(m, 4, 8, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const GlintPixel px = pixel(jac, h, i);
      if (px.D == 0.0) {
        if (e_ref) e_ref[i] = 0.0;
        if (e_alg) e_alg[i] = 0.0;
        continue;
      }
      const double in_disk = gaussian_in_disk_rect(px.xa, px.ya, px.sigma, 0.0, 1.0, 0.0, 1.0);
      if (e_ref) e_ref[i] = px.D * in_disk;  // rho(w) + rho(1 - w) = 1: the roulette keeps the mean
      if (e_alg) e_alg[i] = px.D * expected_alg(px, 1.0, 1.0);
    }
  });
}

// ---------------------------------------------------------------------------------------------------
// Algorithm 2 (docs/math/glinty_ndf.md#glinty-sampling). Per level l, a draw is: x_a uniform on U (a
// draw of the smooth target), its block B(k) of angular cells (block_range, as in Algorithm 1), one
// point i of the block's cells chosen by reservoir sampling with weight R_i f_i M_i(B) (roulette x filter
// x the mass of its lobe inside B), and x from its lobe truncated to B. The lobe of point i is the
// isotropic Gaussian of std sigma_i = alpha_star sqrt(D(T^-1(mu_i))) in the unit square (policy: the
// width at the lobe's own centre, so that each lobe is a Gaussian that can be sampled and integrated
// exactly). The density of x given B is then sum_i R_i f_i N_i(x) 1_B(x) / W_B, W_B = sum_i R_i f_i M_i(B),
// and the density of x is the sum over the blocks B that contain x of P(B) times that, P(B) being the
// probability that x_a chooses B (the area of its region of U, closed form). A block with W_B = 0 (no
// kept point with filter weight) falls back to x = x_a. With probability beta (sample_smooth) the draw
// is x = x_a itself.
double Kpt25Ndf::level_pdf(const GlintPixel& px, int level, double u, double v, std::uint64_t seed, double x,
                           double y) const {
  const std::int64_t na = std::int64_t{1} << level;
  const double fna = static_cast<double>(na), inv_na = 1.0 / fna;
  const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
  const double beta = p_.sample_smooth, four_pi = 4.0 / kPi;
  std::int64_t fx0, fx1, fy0, fy1;
  blocks_containing(x, na, side, fx0, fx1);
  blocks_containing(y, na, side, fy0, fy1);
  const int nbx = static_cast<int>(fx1 - fx0 + 1), nby = static_cast<int>(fy1 - fy0 + 1);  // <= 4 each
  const bool whole = na <= side;
  // The union of the cells of those blocks.
  const std::int64_t a0 = whole ? 0 : fx0, a1 = whole ? na - 1 : fx1 + side - 1;
  const std::int64_t b0 = whole ? 0 : fy0, b1 = whole ? na - 1 : fy1 + side - 1;
  double G[4][4] = {}, W[4][4] = {};
  for_points(
      p_, res_, px, level, px.weights[level == px.levels[0] ? 0 : 1], u, v, seed, a0, a1, b0, b1,
      [&](std::int64_t a, std::int64_t b, double mx, double my, double w, double, double) {
        const double sg = p_.alpha_star * std::sqrt(disk_D(mx, my));
        if (!(sg * sg > 1e-300)) return;  // a lobe narrower than 1e-150: no mass (policy)
        const double ex = x - mx, ey = y - my;
        const double g = w * std::exp(-0.5 * (ex * ex + ey * ey) / (sg * sg)) / (2.0 * kPi * sg * sg);
        double mxs[4], mys[4];
        for (int bx = 0; bx < nbx; ++bx) {
          const std::int64_t f = fx0 + bx;
          const bool in = whole || (a >= f && a < f + side);
          mxs[bx] = !in     ? -1.0
                    : whole ? mass_1d(mx, sg, 0.0, 1.0)
                            : mass_1d(mx, sg, static_cast<double>(f) * inv_na, static_cast<double>(f + side) * inv_na);
        }
        for (int by = 0; by < nby; ++by) {
          const std::int64_t f = fy0 + by;
          const bool in = whole || (b >= f && b < f + side);
          mys[by] = !in     ? -1.0
                    : whole ? mass_1d(my, sg, 0.0, 1.0)
                            : mass_1d(my, sg, static_cast<double>(f) * inv_na, static_cast<double>(f + side) * inv_na);
        }
        for (int bx = 0; bx < nbx; ++bx)
          for (int by = 0; by < nby; ++by)
            if (mxs[bx] >= 0.0 && mys[by] >= 0.0) {
              const double mass = mxs[bx] * mys[by];
              if (p_.sample_lobe_mass) {  // chosen with weight w M_i(B), sampled from N_i 1_B / M_i(B)
                G[bx][by] += g;
                W[bx][by] += w * mass;
              } else if (mass > 0.0) {  // chosen with weight w, sampled from N_i 1_B / M_i(B)
                G[bx][by] += g / mass;
                W[bx][by] += w;
              }
            }
      });
  std::int64_t cx0, cx1, cy0, cy1;  // the block x_a = (x, y) would choose (the fallback's support)
  block_range(x * fna, na, side, cx0, cx1);
  block_range(y * fna, na, side, cy0, cy1);
  double q = 0.0;
  for (int bx = 0; bx < nbx; ++bx)
    for (int by = 0; by < nby; ++by) {
      if (W[bx][by] > 0.0) {
        double xl, xh, yl, yh;
        region_range(fx0 + bx, na, side, xl, xh);
        region_range(fy0 + by, na, side, yl, yh);
        const double P = four_pi * rect_disk_area(xl, xh, yl, yh);
        q += (1.0 - beta) * P * G[bx][by] / W[bx][by];
      } else if (fx0 + bx == cx0 && fy0 + by == cy0) {
        q += (1.0 - beta) * four_pi;  // the fallback x = x_a, uniform on the chosen block's region
      }
    }
  const bool in_u = (x - 0.5) * (x - 0.5) + (y - 0.5) * (y - 0.5) < 0.25;
  return q + (in_u ? beta * four_pi : 0.0);
}

double Kpt25Ndf::pixel_pdf(const GlintPixel& px, double u, double v, std::uint64_t seed, double x, double y) const {
  // The level is drawn with probability w_l (Algorithm 2, lines 4-6): the density is the mixture.
  double q = 0.0;
  for (int l = 0; l < px.n_levels; ++l) q += px.weights[l] * level_pdf(px, px.levels[l], u, v, seed, x, y);
  return q;
}

void Kpt25Ndf::pdf(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                   double* out) const {
  refuse_glint_anisotropy("pdf");
  detail::parallel_chunks(m, 16, 32, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_uv(uv, i);
      const GlintPixel px = pixel(jac, h, i);
      if (px.D == 0.0) {
        out[i] = 0.0;
        continue;
      }
      double hu[3];
      unit_vector(h + 3 * i, hu);
      // dx dy = (pi / 4) D(h) (h.n) dOmega: T maps D(h)(h.n)dOmega to the uniform density 4 / pi on U.
      out[i] = jacobian(px.D, hu[2]) * pixel_pdf(px, uv[2 * i], uv[2 * i + 1], seed, px.xa, px.ya);
    }
  });
}

void Kpt25Ndf::sample(const double* uv, const double* jac, const double* wo, std::size_t m, std::uint64_t seed,
                      std::uint64_t draw_seed, double* h_out, double* pdf_out, double* wi_out) const {
  refuse_glint_anisotropy("sample");
  detail::parallel_chunks(m, 16, 32, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_uv(uv, i);
      double o[3] = {0.0, 0.0, 1.0};
      if (wo) {
        for (int c = 0; c < 3; ++c)
          if (!std::isfinite(wo[3 * i + c]))
            throw_invalid(kWhere, element("wo", i, c), wo[3 * i + c], "a finite direction");
        if (!unit_vector(wo + 3 * i, o))
          throw_invalid(kWhere, row_name("wo", i), row_value(wo + 3 * i, 3), "a nonzero direction");
      }
      GlintPixel px;
      footprint(px, jac, i);
      const double u = uv[2 * i], v = uv[2 * i + 1];
      CounterRng rng = CounterRng::for_index(draw_seed, i, kStreamGlintDraw);
      // x_a uniform on U (line 2: a draw of the smooth target), by the polar map (exact in measure).
      const double ra = 0.5 * std::sqrt(rng.uniform()), phi = 2.0 * kPi * rng.uniform();
      const double xa = 0.5 + ra * std::cos(phi), ya = 0.5 + ra * std::sin(phi);
      const int li = (px.n_levels == 2 && rng.uniform() < px.weights[1]) ? 1 : 0;  // lines 4-6
      const int level = px.levels[li];
      double x = xa, y = ya;
      if (!(rng.uniform() < p_.sample_smooth)) {
        const std::int64_t na = std::int64_t{1} << level;
        const double fna = static_cast<double>(na);
        const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
        std::int64_t a0, a1, b0, b1;
        block_range(xa * fna, na, side, a0, a1);
        block_range(ya * fna, na, side, b0, b1);
        const double bx0 = static_cast<double>(a0) / fna, bx1 = static_cast<double>(a1 + 1) / fna;
        const double by0 = static_cast<double>(b0) / fna, by1 = static_cast<double>(b1 + 1) / fna;
        // Reservoir sampling over the block's points (lines 9-16): keep point i with probability
        // w_i / (sum of the weights so far), which leaves point i chosen with probability w_i / W_B.
        double total = 0.0, gx = 0.0, gy = 0.0, gs = 0.0;
        for_points(p_, res_, px, level, px.weights[li], u, v, seed, a0, a1, b0, b1,
                   [&](std::int64_t, std::int64_t, double mx, double my, double w, double, double) {
                     const double sg = p_.alpha_star * std::sqrt(disk_D(mx, my));
                     if (!(sg * sg > 1e-300)) return;  // a lobe narrower than 1e-150: no mass (policy)
                     const double mass = mass_1d(mx, sg, bx0, bx1) * mass_1d(my, sg, by0, by1);
                     const double wi = p_.sample_lobe_mass ? w * mass : (mass > 0.0 ? w : 0.0);
                     if (!(wi > 0.0)) return;
                     total += wi;
                     if (rng.uniform() * total < wi) {
                       gx = mx;
                       gy = my;
                       gs = sg;
                     }
                   });
        if (total > 0.0) {  // x from the chosen lobe truncated to B (line 14)
          x = truncated_normal(gx, gs, bx0, bx1, rng.uniform());
          y = truncated_normal(gy, gs, by0, by1, rng.uniform());
        }  // else W_B = 0: the fallback x = x_a
      }
      double* H = h_out + 3 * i;
      double* Wi = wi_out ? wi_out + 3 * i : nullptr;
      const auto hv = inverse_map(x, y);
      if (!std::isfinite(hv[0]) || !(hv[2] > 0.0)) {  // the lobe's tail outside U: a lost draw
        H[0] = H[1] = H[2] = kNaN;
        pdf_out[i] = 0.0;
        if (Wi) Wi[0] = Wi[1] = Wi[2] = kNaN;
        continue;
      }
      H[0] = hv[0];
      H[1] = hv[1];
      H[2] = hv[2];
      // The density of the draw, through the same path as pdf() (so that both agree to the bit).
      const auto t = map(H);
      double hu[3];
      unit_vector(H, hu);
      pdf_out[i] = t[2] > 0.0 ? jacobian(t[2], hu[2]) * pixel_pdf(px, u, v, seed, t[0], t[1]) : 0.0;
      if (Wi) {
        const double d = 2.0 * (o[0] * hv[0] + o[1] * hv[1] + o[2] * hv[2]);
        for (int c = 0; c < 3; ++c) Wi[c] = d * hv[c] - o[c];
      }
    }
  });
}

// The visible glints of a pixel (docs/math/glinty_ndf.md#glinty-matched): the points inside DB23's
// footprint ellipse J {|x| <= 1 / sqrt(pi)} (area |det J|; q <= 1 / (pi f^2) in the filter's Mahalanobis
// distance) whose normal lies within `radius` lobe stds of T(h), each counted with its roulette weight
// R (both levels), so that the expected count is K_P |det J| times the area of the angular disk in U.
void Kpt25Ndf::visible_counts(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                              double radius, double* out) const {
  refuse_glint_anisotropy("visible_glints");
  const double q_max = 1.0 / (kPi * p_.filter * p_.filter);
  if (!(q_max <= kFilterRadius * kFilterRadius))
    throw_invalid(kWhere, "filter", p_.filter, "a filter std >= 1 / (3 sqrt(pi)) for visible glint counts");
  if (!(radius > 0.0 && radius <= 10.0)) throw_invalid(kWhere, "radius", radius, "a number of lobe stds in (0, 10]");
  detail::parallel_chunks(m, 16, 32, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_uv(uv, i);
      const GlintPixel px = pixel(jac, h, i);
      double count = 0.0;
      if (px.D > 0.0) {
        const double r = radius * px.sigma, r2 = r * r;
        for (int l = 0; l < px.n_levels; ++l) {
          const int level = px.levels[l];
          const std::int64_t na = std::int64_t{1} << level;
          const double fna = static_cast<double>(na);
          const auto a0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((px.xa - r) * fna)));
          const auto a1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((px.xa + r) * fna)));
          const auto b0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((px.ya - r) * fna)));
          const auto b1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((px.ya + r) * fna)));
          for_points(p_, res_, px, level, px.weights[l], uv[2 * i], uv[2 * i + 1], seed, a0, a1, b0, b1,
                     [&](std::int64_t, std::int64_t, double mx, double my, double, double keep, double q) {
                       const double ex = mx - px.xa, ey = my - px.ya;
                       if (q <= q_max && ex * ex + ey * ey < r2) count += keep;
                     });
        }
      }
      out[i] = count;
    }
  });
}

void Kpt25Ndf::evaluate_rgb(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                            const double* palette, int n_colors, double* out3) const {
  if (n_colors < 1) throw_invalid(kWhere, "colors", static_cast<double>(n_colors), "at least one RGB colour");
  double mean[3] = {0.0, 0.0, 0.0};  // E[GlintColor] (Algorithm 1, line 20): each entry equally likely
  for (int k = 0; k < n_colors; ++k)
    for (int c = 0; c < 3; ++c) mean[c] += palette[3 * k + c] / n_colors;
  detail::parallel_chunks(m, 64, 128, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_uv(uv, i);
      const GlintPixel px = pixel(jac, h, i);
      double* o = out3 + 3 * i;
      o[0] = o[1] = o[2] = 0.0;
      if (px.D == 0.0) continue;
      double rgb[3] = {0.0, 0.0, 0.0}, comp = 0.0;
      for (int l = 0; l < px.n_levels; ++l) {
        level_sum(px, px.levels[l], px.weights[l], uv[2 * i], uv[2 * i + 1], seed, false, nullptr, palette, n_colors,
                  rgb);
        comp += px.weights[l] * compensation(px, px.levels[l]);
      }
      for (int c = 0; c < 3; ++c) o[c] = px.D * (rgb[c] / kp_ + comp * mean[c]);
    }
  });
}

void Kpt25Ndf::reference_rgb(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                             const double* palette, int n_colors, double* out3) const {
  if (n_colors < 1) throw_invalid(kWhere, "colors", static_cast<double>(n_colors), "at least one RGB colour");
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_uv(uv, i);
      const GlintPixel px = pixel(jac, h, i);
      double rgb[3] = {0.0, 0.0, 0.0};
      if (px.D > 0.0)
        for (int l = 0; l < px.n_levels; ++l)
          level_sum(px, px.levels[l], px.weights[l], uv[2 * i], uv[2 * i + 1], seed, true, nullptr, palette, n_colors,
                    rgb);
      for (int c = 0; c < 3; ++c) out3[3 * i + c] = px.D * rgb[c] / kp_;
    }
  });
}

// ---------------------------------------------------------------------------------------------------
// UV-free glints (KPT25 §3.3.6; docs/math/glinty_ndf.md#glinty-triplanar). Three copies of the
// uv-mapped model, one per coordinate plane of the world position, each with its footprint from the
// screen derivatives of its two coordinates, blended by a roulette on the weights w_i.

namespace {

// A dot product and the branchless orthonormal basis of Duff et al. 2017 (JCGT 6(1)) around a unit n:
// the shading frame the half vector is expressed in. For the isotropic targets any frame around n gives
// the same statistics; this one is continuous except where n_z changes sign (documented).
void frame_of(const double n[3], double t[3], double b[3]) {
  const double sign = std::copysign(1.0, n[2]);
  const double a = -1.0 / (sign + n[2]);
  const double c = n[0] * n[1] * a;
  t[0] = 1.0 + sign * n[0] * n[0] * a;
  t[1] = sign * c;
  t[2] = -sign * n[0];
  b[0] = c;
  b[1] = sign + n[1] * n[1] * a;
  b[2] = -n[1];
}

// A plane is dropped when its projected footprint has less than this fraction of the footprint's area
// (|dP/dx x dP/dy . e_i| / |dP/dx x dP/dy|): its MIP level and filter would be those of a line, and its
// weight is then at most about this fraction with normalised |n_i| weights (the weights are
// renormalised over the planes kept, so dropping one leaves the mean unchanged).
constexpr double kPlaneMinArea = 1e-6;

}  // namespace

void Kpt25Ndf::refuse_triplanar_options() const {
  refuse_glint_anisotropy("triplanar glints (the paper: no uv gradients to orient A_* by)");
  if (aniso_)
    throw_invalid(kWhere, "alpha_y", p_.alpha_y,
                  "alpha_y = alpha (isotropic roughness) for triplanar glints (no tangent frame to orient it by)");
}

std::array<double, 3> Kpt25Ndf::triplanar_weights(const double nin[3]) const {
  double n[3];
  if (!unit_vector(nin, n)) return {0.0, 0.0, 0.0};
  std::array<double, 3> w{};
  double sum = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double a = std::abs(n[c]);
    w[c] = p_.triplanar_sharpness == 1.0 ? a : std::pow(a, p_.triplanar_sharpness);
    sum += w[c];
  }
  if (p_.triplanar_weights != TriplanarWeights::printed)
    for (double& x : w) x /= sum;
  if (p_.triplanar_weights == TriplanarWeights::missing_xy) w[2] = 0.0;
  return w;
}

int Kpt25Ndf::triplanar_planes(const double* P, const double* dP, const double* n, const double* h, std::size_t i,
                               TriplanarPlane planes[3], double h_t[3]) const {
  static constexpr double kOrigin[3] = {0.0, 0.0, 0.0};  // P = nullptr: positions not needed (expectations)
  const double* p = P ? P + 3 * i : kOrigin;
  const double* d = dP + 6 * i;
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(p[c]) || std::abs(p[c]) > 1e9)
      throw_invalid(kWhere, element("position", i, c), p[c], "a finite position, |P| <= 1e9");
  for (int c = 0; c < 6; ++c)
    if (!std::isfinite(d[c]) || std::abs(d[c]) > 1e12)
      throw_invalid(kWhere, element("dP", i, c), d[c], "a finite derivative, |dP| <= 1e12");
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(n[3 * i + c])) throw_invalid(kWhere, element("n", i, c), n[3 * i + c], "a finite normal");
    if (!std::isfinite(h[3 * i + c])) throw_invalid(kWhere, element("h", i, c), h[3 * i + c], "a finite half vector");
  }
  double nu[3], hu[3];
  if (!unit_vector(n + 3 * i, nu)) throw_invalid(kWhere, row_name("n", i), row_value(n + 3 * i, 3), "a nonzero normal");
  if (!unit_vector(h + 3 * i, hu))
    throw_invalid(kWhere, row_name("h", i), row_value(h + 3 * i, 3), "a nonzero half vector");
  double t[3], b[3];
  frame_of(nu, t, b);
  h_t[0] = hu[0] * t[0] + hu[1] * t[1] + hu[2] * t[2];
  h_t[1] = hu[0] * b[0] + hu[1] * b[1] + hu[2] * b[2];
  h_t[2] = hu[0] * nu[0] + hu[1] * nu[1] + hu[2] * nu[2];
  // The footprint's normal area vector dP/dx x dP/dy: its component along axis c is the det J of plane c.
  const double cr[3] = {d[1] * d[5] - d[2] * d[4], d[2] * d[3] - d[0] * d[5], d[0] * d[4] - d[1] * d[3]};
  const double area = std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  if (!(area > 0.0))
    throw_invalid(kWhere, row_name("dP", i), row_value(d, 6),
                  "screen derivatives with dP/dx x dP/dy != 0 (mask pixels that do not see the surface)");
  auto w = triplanar_weights(nu);
  static constexpr int kAxes[3][2] = {{1, 2}, {0, 2}, {0, 1}};  // the coordinates of the yz, xz, xy planes
  double kept_sum = 0.0;
  int count = 0;
  for (int c = 0; c < 3; ++c) {
    if (!(w[c] > 0.0) || !(std::abs(cr[c]) > kPlaneMinArea * area)) continue;
    if (p_.triplanar_weights == TriplanarWeights::missing_xy && c == 2) continue;
    TriplanarPlane& pl = planes[count++];
    pl.axis = c;
    pl.u = p[kAxes[c][0]];
    pl.v = p[kAxes[c][1]];
    pl.J[0] = d[kAxes[c][0]];      // du/dx
    pl.J[1] = d[kAxes[c][1]];      // dv/dx
    pl.J[2] = d[3 + kAxes[c][0]];  // du/dy
    pl.J[3] = d[3 + kAxes[c][1]];  // dv/dy
    pl.weight = w[c];
    pl.tag = p_.triplanar_shared_seeds ? 0u : static_cast<std::uint32_t>(c + 1);
    kept_sum += w[c];
  }
  // Renormalise over the planes kept (normalised weights only: the printed ones stay as printed, and the
  // deliberately wrong blend keeps its missing plane's share lost).
  const double full = w[0] + w[1] + w[2];
  if (p_.triplanar_weights == TriplanarWeights::normalized && kept_sum > 0.0 && kept_sum < full)
    for (int k = 0; k < count; ++k) planes[k].weight *= full / kept_sum;
  return count;
}

GlintPixel Kpt25Ndf::plane_pixel(const TriplanarPlane& pl, const double h_t[3], std::size_t i) const {
  try {
    return pixel(pl.J, h_t, 0);
  } catch (const std::invalid_argument& e) {  // name the caller's pixel and the plane
    static constexpr const char* kPlanes[3] = {"yz", "xz", "xy"};
    throw_invalid_message(std::string(e.what()) + " (triplanar pixel " + std::to_string(i) + ", " + kPlanes[pl.axis] +
                          " plane: J = the derivatives of its two coordinates of P)");
  }
}

void Kpt25Ndf::evaluate_triplanar(const double* P, const double* dP, const double* n, const double* h, std::size_t m,
                                  std::uint64_t seed, double* out) const {
  refuse_triplanar_options();
  detail::parallel_chunks(m, 32, 64, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      TriplanarPlane planes[3];
      double h_t[3];
      const int np = triplanar_planes(P, dP, n, h, i, planes, h_t);
      double value = 0.0;
      for (int k = 0; k < np; ++k) {
        const GlintPixel px = plane_pixel(planes[k], h_t, i);
        if (px.D == 0.0) continue;
        double explicit_sum = 0.0, comp = 0.0;
        for (int l = 0; l < px.n_levels; ++l) {
          explicit_sum += level_sum(px, px.levels[l], px.weights[l], planes[k].u, planes[k].v, seed, false, nullptr,
                                    nullptr, 0, nullptr, planes[k].weight, planes[k].tag);
          comp += px.weights[l] * compensation(px, px.levels[l]);
        }
        value += px.D * (explicit_sum / kp_ + planes[k].weight * comp);  // compensation blended linearly
      }
      out[i] = value;
    }
  });
}

void Kpt25Ndf::reference_triplanar(const double* P, const double* dP, const double* n, const double* h, std::size_t m,
                                   std::uint64_t seed, double* out, double* out_points) const {
  refuse_triplanar_options();
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      TriplanarPlane planes[3];
      double h_t[3];
      const int np = triplanar_planes(P, dP, n, h, i, planes, h_t);
      double value = 0.0, kept = 0.0;
      for (int k = 0; k < np; ++k) {
        const GlintPixel px = plane_pixel(planes[k], h_t, i);
        if (px.D == 0.0) continue;
        double sum = 0.0;
        for (int l = 0; l < px.n_levels; ++l)
          sum += level_sum(px, px.levels[l], px.weights[l], planes[k].u, planes[k].v, seed, true, nullptr, nullptr, 0,
                           nullptr, planes[k].weight, planes[k].tag, &kept);
        value += px.D * sum / kp_;
      }
      out[i] = value;
      if (out_points) out_points[i] = kept;
    }
  });
}

void Kpt25Ndf::expected_triplanar(const double* dP, const double* n, const double* h, std::size_t m, double* e_ref,
                                  double* e_alg) const {
  refuse_triplanar_options();
  detail::parallel_chunks(m, 4, 8, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      TriplanarPlane planes[3];
      double h_t[3];
      const int np = triplanar_planes(nullptr, dP, n, h, i, planes, h_t);  // positions do not enter
      double er = 0.0, ea = 0.0;
      for (int k = 0; k < np; ++k) {
        const GlintPixel px = plane_pixel(planes[k], h_t, i);
        if (px.D == 0.0) continue;
        const double rho = keep_rate(planes[k].weight);
        er += rho * px.D * gaussian_in_disk_rect(px.xa, px.ya, px.sigma, 0.0, 1.0, 0.0, 1.0);
        ea += px.D * expected_alg(px, rho, planes[k].weight);
      }
      if (e_ref) e_ref[i] = er;
      if (e_alg) e_alg[i] = ea;
    }
  });
}

}  // namespace glintlab
