// KPT25's Algorithm 2: sampling the glinty NDF of a pixel and its exact pdf (glinty_ndf.hpp,
// docs/math/glinty_ndf.md#glinty-sampling).
#include <algorithm>
#include <boost/math/special_functions/erf.hpp>
#include <cmath>
#include <cstdint>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"
#include "kpt25_internal.hpp"

namespace glintlab {

using namespace kpt25;  // NOLINT(google-build-using-namespace): this file's own helpers

namespace {

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

}  // namespace

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
  const double weight = px.weights[level == px.levels[0] ? 0 : 1];
  std::int64_t fx0, fx1, fy0, fy1;
  blocks_containing(x, na, side, fx0, fx1);
  blocks_containing(y, na, side, fy0, fy1);
  const int nbx = static_cast<int>(fx1 - fx0 + 1), nby = static_cast<int>(fy1 - fy0 + 1);  // <= 4 each
  const bool whole = na <= side;
  // The union of the cells of those blocks.
  const CellRange cells{whole ? 0 : fx0, whole ? na - 1 : fx1 + side - 1, whole ? 0 : fy0,
                        whole ? na - 1 : fy1 + side - 1};
  double G[4][4] = {}, W[4][4] = {};
  // The mass of a lobe along one axis in the block whose first cell is f (-1: the point is not in it).
  auto axis_mass = [&](std::int64_t cell, std::int64_t f, double m, double sg) {
    if (!(whole || (cell >= f && cell < f + side))) return -1.0;
    if (whole) return mass_1d(m, sg, 0.0, 1.0);
    return mass_1d(m, sg, static_cast<double>(f) * inv_na, static_cast<double>(f + side) * inv_na);
  };
  for_each_point(res_, px, level, u, v, seed, 0, cells,
                 [&](std::int64_t i, std::int64_t j, std::int64_t a, std::int64_t b, double mx, double my, double q) {
                   const double keep = point_keep(p_, seed, level, i, j, a, b, weight);
                   if (keep == 0.0) return;
                   const double w = keep * std::exp(-0.5 * q);
                   const double sg = p_.alpha_star * std::sqrt(disk_D(mx, my));
                   if (!(sg * sg > 1e-300)) return;  // a lobe narrower than 1e-150: no mass (policy)
                   const double ex = x - mx, ey = y - my;
                   const double g = w * std::exp(-0.5 * (ex * ex + ey * ey) / (sg * sg)) / (2.0 * kPi * sg * sg);
                   double mxs[4], mys[4];
                   for (int bx = 0; bx < nbx; ++bx) mxs[bx] = axis_mass(a, fx0 + bx, mx, sg);
                   for (int by = 0; by < nby; ++by) mys[by] = axis_mass(b, fy0 + by, my, sg);
                   for (int bx = 0; bx < nbx; ++bx)
                     for (int by = 0; by < nby; ++by) {
                       if (!(mxs[bx] >= 0.0 && mys[by] >= 0.0)) continue;
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
  const CellRange chosen = block_cells(x, y, level, p_.k);  // the block x_a = (x, y) would choose (the fallback)
  double q = 0.0;
  for (int bx = 0; bx < nbx; ++bx)
    for (int by = 0; by < nby; ++by) {
      if (W[bx][by] > 0.0) {
        double xl, xh, yl, yh;
        region_range(fx0 + bx, na, side, xl, xh);
        region_range(fy0 + by, na, side, yl, yh);
        const double P = four_pi * rect_disk_area(xl, xh, yl, yh);
        q += (1.0 - beta) * P * G[bx][by] / W[bx][by];
      } else if (fx0 + bx == chosen.a0 && fy0 + by == chosen.b0) {
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
      check_position("uv", uv, i, 2, cells_per_uv_);
      const GlintPixel px = pixel(jac, h, i);
      if (px.D == 0.0) {
        out[i] = 0.0;
        continue;
      }
      double hu[3];
      unit_vector(h + 3 * i, hu);
      // dx dy = |J_T| dOmega: the density on U, times the map's Jacobian, is the density per steradian.
      out[i] = jacobian(px.D, hu) * pixel_pdf(px, uv[2 * i], uv[2 * i + 1], seed, px.xa, px.ya);
    }
  });
}

// Lines 7-16 of Algorithm 2 at one level: the point (x, y) of U drawn from the lobes of the block B(k)
// of x_a, by reservoir sampling over its points; false when the block has no weight (W_B = 0).
bool Kpt25Ndf::draw_from_block(const GlintPixel& px, int li, double u, double v, std::uint64_t seed, double xa,
                               double ya, CounterRng& rng, double& x, double& y) const {
  const int level = px.levels[li];
  const double fna = static_cast<double>(std::int64_t{1} << level);
  const CellRange block = block_cells(xa, ya, level, p_.k);
  const double bx0 = static_cast<double>(block.a0) / fna, bx1 = static_cast<double>(block.a1 + 1) / fna;
  const double by0 = static_cast<double>(block.b0) / fna, by1 = static_cast<double>(block.b1 + 1) / fna;
  // Reservoir sampling over the block's points (lines 9-16): keep point i with probability
  // w_i / (sum of the weights so far), which leaves point i chosen with probability w_i / W_B.
  double total = 0.0, gx = 0.0, gy = 0.0, gs = 0.0;
  for_each_point(res_, px, level, u, v, seed, 0, block,
                 [&](std::int64_t i, std::int64_t j, std::int64_t a, std::int64_t b, double mx, double my, double q) {
                   const double keep = point_keep(p_, seed, level, i, j, a, b, px.weights[li]);
                   if (keep == 0.0) return;
                   const double w = keep * std::exp(-0.5 * q);
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
  if (!(total > 0.0)) return false;
  x = truncated_normal(gx, gs, bx0, bx1, rng.uniform());  // the chosen lobe truncated to B (line 14)
  y = truncated_normal(gy, gs, by0, by1, rng.uniform());
  return true;
}

void Kpt25Ndf::sample(const double* uv, const double* jac, const double* wo, std::size_t m, std::uint64_t seed,
                      std::uint64_t draw_seed, double* h_out, double* pdf_out, double* wi_out) const {
  refuse_glint_anisotropy("sample");
  detail::parallel_chunks(m, 16, 32, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
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
      double x = xa, y = ya;  // the fallback (W_B = 0) and the smooth share: x = x_a
      if (!(rng.uniform() < p_.sample_smooth)) draw_from_block(px, li, u, v, seed, xa, ya, rng, x, y);
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
      pdf_out[i] = t[2] > 0.0 ? jacobian(t[2], hu) * pixel_pdf(px, u, v, seed, t[0], t[1]) : 0.0;
      if (Wi) {
        // A half vector facing away from wo (wo.h <= 0) reflects wo off the back of its facet: no wi
        // (NaN; policy, docs/math/glinty_ndf.md#glinty-sampling). The other draws' wi are exactly the
        // directions whose half vector normalise(wi + wo) has wo.h > 0, so the density of wi is
        // pdf(h) / (4 wo.h) at that h, with nothing else mapped onto the same wi.
        const double dot = o[0] * hv[0] + o[1] * hv[1] + o[2] * hv[2];
        for (int c = 0; c < 3; ++c) Wi[c] = dot > 0.0 ? 2.0 * dot * hv[c] - o[c] : kNaN;
      }
    }
  });
}

}  // namespace glintlab
