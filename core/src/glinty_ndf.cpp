// KPT25's glinty NDF: point process, reference and Algorithm 1 (glinty_ndf.hpp, docs/math/glinty_ndf.md).
#include "glintlab/glinty_ndf.hpp"

#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

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
constexpr double kUnderflowRadius = 39.0;
// Random numbers of the points: a stream id of their own in the top byte of the last counter word, so
// they share nothing with the other users of a seed (rng.hpp keeps stream ids below 256 in the low
// 16 bits with the level above, a word below 2^24 for every level in use).
constexpr std::uint32_t kStreamGlintPoints = 8;

// Phi(b) - Phi(a) for a <= b without cancellation in either tail.
double normal_mass(double a, double b) {
  if (!(b > a)) return 0.0;
  if (a >= 0.0) return 0.5 * (std::erfc(a * kSqrt1_2) - std::erfc(b * kSqrt1_2));
  if (b <= 0.0) return 0.5 * (std::erfc(-b * kSqrt1_2) - std::erfc(-a * kSqrt1_2));
  return 1.0 - 0.5 * (std::erfc(-a * kSqrt1_2) + std::erfc(b * kSqrt1_2));
}

// Mass of N(c, sigma^2) in [lo, hi].
double mass_1d(double c, double sigma, double lo, double hi) { return normal_mass((lo - c) / sigma, (hi - c) / sigma); }

// One Philox block of a point: counter (2 a + block, i, j, stream << 24 | level << 20 | b), key = seed.
// a, b < 2^15 and level <= 15 fit (kGlintMaxLevel).
std::array<std::uint32_t, 4> point_block(std::uint64_t seed, int level, std::int64_t i, std::int64_t j, std::int64_t a,
                                         std::int64_t b, std::uint32_t block) {
  const std::array<std::uint32_t, 4> counter = {
      static_cast<std::uint32_t>(2 * a) + block, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j),
      (kStreamGlintPoints << 24) | (static_cast<std::uint32_t>(level) << 20) | static_cast<std::uint32_t>(b)};
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

}  // namespace

double kpt25_roulette(double r, double w, double eps) {
  const double lo = std::max(0.0, r - eps), hi = std::min(1.0, r + eps);
  if (!(hi > lo)) return w >= r ? 1.0 : 0.0;  // eps = 0: the exact roulette (Heaviside)
  const double t = std::clamp((w - lo) / (hi - lo), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

double gaussian_in_disk_rect(double cx, double cy, double sigma, double x0, double x1, double y0, double y1) {
  const double a = std::max({x0, 0.0, cx - 12.0 * sigma}), b = std::min({x1, 1.0, cx + 12.0 * sigma});
  if (!(b > a) || !(y1 > y0)) return 0.0;
  auto f = [&](double x) {
    const double s = std::sqrt(std::max(0.0, 0.25 - (x - 0.5) * (x - 0.5)));
    const double lo = std::max(y0, 0.5 - s), hi = std::min(y1, 0.5 + s);
    if (!(hi > lo)) return 0.0;
    const double z = (x - cx) / sigma;
    return std::exp(-0.5 * z * z) / (sigma * std::sqrt(2.0 * kPi)) * mass_1d(cy, sigma, lo, hi);
  };
  return boost::math::quadrature::gauss_kronrod<double, 31>::integrate(f, a, b, 20, 1e-11);
}

Kpt25Ndf::Kpt25Ndf(const Kpt25Params& params) : p_(params) {
  if (!(p_.density > 0.0 && p_.density <= 1e18)) throw_invalid(kWhere, "density", p_.density, "a number in (0, 1e18]");
  if (!(p_.alpha > 0.0 && std::isfinite(p_.alpha))) throw_invalid(kWhere, "alpha", p_.alpha, "a finite number > 0");
  if (!(p_.alpha_star > 0.0 && std::isfinite(p_.alpha_star)))
    throw_invalid(kWhere, "alpha_star", p_.alpha_star, "a finite number > 0");
  if (!(p_.k == 1 || p_.k == 4 || p_.k == 9 || p_.k == 16))
    throw_invalid(kWhere, "k", static_cast<double>(p_.k), "1, 4, 9 or 16 (a square block of angular cells)");
  if (!(p_.epsilon >= 0.0 && p_.epsilon <= 0.5)) throw_invalid(kWhere, "epsilon", p_.epsilon, "a number in [0, 0.5]");
  if (!(p_.filter > 0.0 && std::isfinite(p_.filter)))
    throw_invalid(kWhere, "filter", p_.filter, "a finite pixel filter std > 0 (pixels)");
  res_ = std::sqrt(p_.density);
}

std::array<double, 3> Kpt25Ndf::map(const double hin[3]) const {
  const double len = std::sqrt(hin[0] * hin[0] + hin[1] * hin[1] + hin[2] * hin[2]);
  const double hx = hin[0] / len, hy = hin[1] / len, hz = hin[2] / len;
  if (!(hz > 0.0)) return {0.5, 0.5, 0.0};  // below the horizon: D = 0, the position is irrelevant
  const double a2 = p_.alpha * p_.alpha;
  double dx, dy, D;
  if (p_.target == GlintTarget::beckmann) {
    // Slopes s = (hx, hy) / hz are Gaussian (variance alpha^2 / 2 per axis) under D(h)(h.n)dh, so
    // |d|^2 = 1 - exp(-|s|^2 / alpha^2) is uniform and d = s |d| / |s| is uniform on the unit disk
    // (the inverse of §3.2.2's B1, Marsaglia's polar map). -expm1(-t)/t stays accurate as t -> 0.
    const double sx = hx / hz, sy = hy / hz, t = (sx * sx + sy * sy) / a2;
    const double scale = t > 1e-300 ? std::sqrt(-std::expm1(-t) / t) / p_.alpha : 1.0 / p_.alpha;
    dx = sx * scale;
    dy = sy * scale;
    const double c2 = hz * hz;
    D = std::exp(-t) / (kPi * a2 * c2 * c2);
  } else {
    // GGX: the stretched half vector (hx / alpha, hy / alpha, hz), normalised, is cosine distributed
    // under D(h)(h.n)dh (§3.2.1's M~ with M = diag(1/alpha, 1/alpha, 1)); its orthographic projection
    // (x, y) is then uniform on the unit disk (docs/math/glinty_ndf.md#glinty-map: not the Lambert
    // projection of eq. 7, which makes a uniform hemisphere uniform, not a cosine-weighted one).
    const double px = hx / p_.alpha, py = hy / p_.alpha;
    const double n = std::sqrt(px * px + py * py + hz * hz);
    dx = px / n;
    dy = py / n;
    const double q = (a2 - 1.0) * hz * hz + 1.0;
    D = a2 / (kPi * q * q);
  }
  return {0.5 + 0.5 * dx, 0.5 + 0.5 * dy, D};
}

GlintPixel Kpt25Ndf::pixel(const double* jac, const double* h, std::size_t i) const {
  GlintPixel px;
  px.index = i;
  const double* J = jac + 4 * i;
  const double* H = h + 3 * i;
  for (int c = 0; c < 4; ++c)
    if (!std::isfinite(J[c]) || std::abs(J[c]) > 1e12)
      throw_invalid(kWhere, indexed_name("J", 4 * i + c, true), J[c], "a finite derivative, |J| <= 1e12");
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(H[c])) throw_invalid(kWhere, indexed_name("h", 3 * i + c, true), H[c], "a finite half vector");
  const double hlen2 = H[0] * H[0] + H[1] * H[1] + H[2] * H[2];
  if (!(hlen2 > 1e-300)) throw_invalid(kWhere, indexed_name("h", 3 * i, true), H[0], "a nonzero half vector");
  const auto m = map(H);
  px.xa = m[0];
  px.ya = m[1];
  px.D = m[2];
  px.sigma = p_.alpha_star * std::sqrt(px.D);
  // Spatial covariance f^2 J J^T (Algorithm 1, line 11) with J = [[du/dx, du/dy], [dv/dx, dv/dy]].
  const double f2 = p_.filter * p_.filter;
  const double suu = f2 * (J[0] * J[0] + J[2] * J[2]), svv = f2 * (J[1] * J[1] + J[3] * J[3]);
  const double suv = f2 * (J[0] * J[1] + J[2] * J[3]);
  const double detj = J[0] * J[3] - J[1] * J[2];
  const double det = f2 * f2 * detj * detj;
  if (!(det > 0.0) || !(det > 1e-24 * suu * svv))
    throw_invalid(kWhere, indexed_name("J", 4 * i, true), detj,
                  "a footprint with det J != 0 and anisotropy below 1e12 (mask pixels that do not see the surface)");
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
    throw_invalid(kWhere, indexed_name("J", 4 * i, true), J[0],
                  "a footprint small enough for the density (MIP level " + std::to_string(px.lambda) +
                      " > " + std::to_string(kGlintMaxLevel) + "; lower the density or the footprint)");
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
  return px;
}

double Kpt25Ndf::level_sum(const GlintPixel& px, int level, double weight, double u, double v, std::uint64_t seed,
                           bool all_angular, double* points) const {
  const double cell = std::ldexp(1.0, level) / res_;  // spatial cell side at this level
  const std::int64_t na = std::int64_t{1} << level;   // angular cells per axis
  const double fna = static_cast<double>(na);
  const auto i0 = static_cast<std::int64_t>(std::floor((u - px.half_u) / cell));
  const auto i1 = static_cast<std::int64_t>(std::floor((u + px.half_u) / cell));
  const auto j0 = static_cast<std::int64_t>(std::floor((v - px.half_v) / cell));
  const auto j1 = static_cast<std::int64_t>(std::floor((v + px.half_v) / cell));
  std::int64_t a0, a1, b0, b1;
  if (all_angular) {
    const double reach = kUnderflowRadius * px.sigma;
    a0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((px.xa - reach) * fna)));
    a1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((px.xa + reach) * fna)));
    b0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((px.ya - reach) * fna)));
    b1 = std::min<std::int64_t>(na - 1, static_cast<std::int64_t>(std::floor((px.ya + reach) * fna)));
    const double cells = static_cast<double>(i1 - i0 + 1) * static_cast<double>(j1 - j0 + 1) *
                         static_cast<double>(std::max<std::int64_t>(0, a1 - a0 + 1)) *
                         static_cast<double>(std::max<std::int64_t>(0, b1 - b0 + 1));
    if (cells > kGlintMaxReferenceCells)
      throw_invalid(kWhere, indexed_name("J", 4 * px.index, true), static_cast<double>(px.index),
                    "a footprint whose reference sums at most 2e8 cells (this one: " + format_value(cells) +
                        " at level " + std::to_string(level) + "; lower the density or the footprint)");
  } else {
    const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
    block_range(px.xa * fna, na, side, a0, a1);
    block_range(px.ya * fna, na, side, b0, b1);
  }
  const double inv_na = 1.0 / static_cast<double>(na);
  const double inv2s2 = 0.5 / (px.sigma * px.sigma);
  const bool roulette = p_.blend == GlintBlend::roulette && weight < 1.0;
  double sum = 0.0, count = 0.0;
  for (std::int64_t i = i0; i <= i1; ++i) {
    for (std::int64_t j = j0; j <= j1; ++j) {
      for (std::int64_t a = a0; a <= a1; ++a) {
        for (std::int64_t b = b0; b <= b1; ++b) {
          const auto r4 = point_block(seed, level, i, j, a, b, 0);
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
          if (roulette) keep = kpt25_roulette(unit(point_block(seed, level, i, j, a, b, 1)[0]), weight, p_.epsilon);
          if (keep == 0.0) continue;
          const double ex = mx - px.xa, ey = my - px.ya;
          sum += keep * px.norm * std::exp(-0.5 * q - (ex * ex + ey * ey) * inv2s2);
        }
      }
    }
  }
  if (points) *points += count;
  // The angular Gaussian's normalisation 1 / (2 pi sigma^2) (a 2D density: eq. 4 prints the 1D one).
  return sum / (2.0 * kPi * px.sigma * px.sigma);
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
  const double square = mass_1d(px.xa, s, 0.0, 1.0) * mass_1d(px.ya, s, 0.0, 1.0);
  const double in_b = mass_1d(px.xa, s, bx0, bx1) * mass_1d(px.ya, s, by0, by1);
  return p_.compensation == GlintCompensation::square_flipped ? square + in_b : square - in_b;
}

void Kpt25Ndf::evaluate(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                        double* out) const {
  detail::parallel_chunks(m, 64, 128, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double u = uv[2 * i], v = uv[2 * i + 1];
      if (!std::isfinite(u) || !std::isfinite(v) || std::abs(u) > 1e9 || std::abs(v) > 1e9)
        throw_invalid(kWhere, indexed_name("uv", 2 * i, true), std::isfinite(u) ? v : u, "a finite position, |uv| <= 1e9");
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
      out[i] = px.D * (explicit_sum / p_.density + comp);  // eq. 11 with |J_T| read as D(h)
    }
  });
}

void Kpt25Ndf::reference(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                         double* out, double* out_points) const {
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const double u = uv[2 * i], v = uv[2 * i + 1];
      if (!std::isfinite(u) || !std::isfinite(v) || std::abs(u) > 1e9 || std::abs(v) > 1e9)
        throw_invalid(kWhere, indexed_name("uv", 2 * i, true), std::isfinite(u) ? v : u, "a finite position, |uv| <= 1e9");
      const GlintPixel px = pixel(jac, h, i);
      double points = 0.0, sum = 0.0;
      if (px.D > 0.0)
        for (int l = 0; l < px.n_levels; ++l)
          sum += level_sum(px, px.levels[l], px.weights[l], u, v, seed, true, &points);
      out[i] = px.D * sum / p_.density;
      if (out_points) out_points[i] = points;
    }
  });
}

void Kpt25Ndf::expected(const double* jac, const double* h, std::size_t m, double* e_ref, double* e_alg) const {
  // E over r of R(r, w): w for the linear blend and in the interior of the roulette; by quadrature at
  // the ends, where the clamps of eq. 8 make it differ from w (rho(w) + rho(1 - w) = 1 still holds).
  auto rho = [&](double w) {
    if (p_.blend == GlintBlend::linear || w >= 1.0) return w;
    if (p_.epsilon == 0.0) return w;
    auto f = [&](double r) { return kpt25_roulette(r, w, p_.epsilon); };
    double total = 0.0;
    double cuts[] = {0.0, std::clamp(w - p_.epsilon, 0.0, 1.0), std::clamp(w + p_.epsilon, 0.0, 1.0),
                     std::min(p_.epsilon, 1.0), std::max(0.0, 1.0 - p_.epsilon), 1.0};
    std::sort(std::begin(cuts), std::end(cuts));
    for (int c = 0; c + 1 < 6; ++c)
      if (cuts[c + 1] > cuts[c])
        total += boost::math::quadrature::gauss_kronrod<double, 15>::integrate(f, cuts[c], cuts[c + 1], 10, 1e-13);
    return total;
  };
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
      if (!e_alg) continue;
      double total = 0.0;
      const int side = static_cast<int>(std::lround(std::sqrt(p_.k)));
      for (int l = 0; l < px.n_levels; ++l) {
        const std::int64_t na = std::int64_t{1} << px.levels[l];
        const double fna = static_cast<double>(na);
        std::int64_t a0, a1, b0, b1;
        block_range(px.xa * fna, na, side, a0, a1);
        block_range(px.ya * fna, na, side, b0, b1);
        const double inv = 1.0 / static_cast<double>(na);
        const double in_b = gaussian_in_disk_rect(px.xa, px.ya, px.sigma, static_cast<double>(a0) * inv,
                                                  static_cast<double>(a1 + 1) * inv, static_cast<double>(b0) * inv,
                                                  static_cast<double>(b1 + 1) * inv);
        total += rho(px.weights[l]) * in_b + px.weights[l] * compensation(px, px.levels[l]);
      }
      e_alg[i] = px.D * total;
    }
  });
}

}  // namespace glintlab
