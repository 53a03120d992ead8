// The mollified roulette's moments and row kernels (core/blends/roulette.cpp; docs/math/blends.md,
// "roulette"): internal to the library and its tests.
//
// The closed-form moments are inline and branch-free (selects, no division) so that the scalar rule
// and the vector row kernels (core/src/counting/roulette_rows*.cpp) compile the very same IEEE operations in
// the same order: neither contracts products and sums into FMAs (the scalar code is built for the
// x86-64 baseline, which has none; the kernels with -ffp-contract=off), so both give the same bits.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace glintlab::blend_detail {

// eps's derived constants, by the same expressions wherever the moments are computed. Below
// kRouletteVanishingEps (where 1 / (2 eps) nears overflow) the moments are their eps -> 0 limit, the
// hard roulette's (w, w): off by O(eps) < 1e-300.
inline constexpr double kRouletteVanishingEps = 1e-300;
struct RouletteEps {
  double eps, two_eps, inv_two_eps, one_minus_eps;
  bool vanishing;
  explicit RouletteEps(double e)
      : eps(e), two_eps(2.0 * e), inv_two_eps(1.0 / (2.0 * e)), one_minus_eps(1.0 - e),
        vanishing(!(e >= kRouletteVanishingEps)) {}
};

// std::clamp's comparisons, written out so that vector loops see a select.
inline double roulette_clamp(double x, double lo, double hi) { return x < lo ? lo : (hi < x ? hi : x); }

// r in [0, eps]: the window [0, r + eps], t = w / s with s = r + eps in [eps, 2 eps]; R = 1 where
// s <= w. With c = clamp(w, eps, 2 eps), s in [eps, c] gives c - eps (exact: Sterbenz), and the rest,
// rational in s, is a polynomial in t = w / s (ds = -w dt / t^2):
//   int_c^{2 eps} S(w / s)^j ds = w int_{t0}^{t1} S(t)^j / t^2 dt,  t0 = w / 2eps, t1 = w / c,
// with S / t^2 = 3 - 2t (antiderivative 3t - t^2) and S^2 / t^2 = t^2 (3 - 2t)^2 (antiderivative
// 3t^3 - 3t^4 + 4t^5/5). t1 is 2 t0 (c = eps), 1 (c = w) or t0 (c = 2 eps: no ramp); every t is in
// [0, 1] for w in [0, 1]. For w in [0, 1].
inline void roulette_left_end(double w, const RouletteEps& c, double& a1, double& a2) {
  const double t0 = w * c.inv_two_eps;
  const double t1 = w <= c.eps ? 2.0 * t0 : (w < c.two_eps ? 1.0 : t0);
  const double saturated = (w <= c.eps ? c.eps : (w < c.two_eps ? w : c.two_eps)) - c.eps;
  // No ramp at w >= 2 eps (t1 = t0): 0, written as a select because t0 = w / 2eps may be so large
  // there that its powers overflow (inf - inf).
  const bool ramp = w < c.two_eps;
  const double g1 = ramp ? t1 * (3.0 - t1) - t0 * (3.0 - t0) : 0.0;
  const double g2 =
      ramp ? t1 * t1 * t1 * (3.0 + t1 * (-3.0 + 0.8 * t1)) - t0 * t0 * t0 * (3.0 + t0 * (-3.0 + 0.8 * t0)) : 0.0;
  a1 = saturated + w * g1;
  a2 = saturated + w * g2;
}

// r in [eps, 1 - eps]: the whole window, t = (w - r + eps) / 2eps linear in r: R = 1 for r <= w - eps,
// 0 for r >= w + eps, and between them 2 eps times the integral of S^j over t (antiderivatives
// t^3 - t^4/2 and 9t^5/5 - 2t^6 + 4t^7/7). Empty at eps = 1/2 (r1 = r2, ta = tb).
inline void roulette_middle(double w, const RouletteEps& c, double& m1, double& m2) {
  const double r1 = roulette_clamp(w - c.eps, c.eps, c.one_minus_eps);
  const double r2 = roulette_clamp(w + c.eps, c.eps, c.one_minus_eps);
  const double ta = roulette_clamp(((w - r1) + c.eps) * c.inv_two_eps, 0.0, 1.0);  // ta >= tb
  const double tb = roulette_clamp(((w - r2) + c.eps) * c.inv_two_eps, 0.0, 1.0);
  const double p1 = ta * ta * ta * (1.0 - 0.5 * ta) - tb * tb * tb * (1.0 - 0.5 * tb);
  const double ta2 = ta * ta, tb2 = tb * tb;
  const double p2 =
      ta2 * ta2 * ta * (1.8 + ta * (-2.0 + ta * (4.0 / 7.0))) - tb2 * tb2 * tb * (1.8 + tb * (-2.0 + tb * (4.0 / 7.0)));
  m1 = (r1 - c.eps) + c.two_eps * p1;
  m2 = (r1 - c.eps) + c.two_eps * p2;
}

// {E[R], E[R^2]} over r in [0, eps], [eps, 1 - eps] and [1 - eps, 1], for w in (0, 1). The last by
// the smoothstep's symmetry R(r, w) = 1 - R(1 - r, 1 - w): with (a1, a2) the first piece at 1 - w,
// it is eps - a1 for R and eps - 2 a1 + a2 for R^2.
inline std::array<std::array<double, 2>, 3> roulette_moment_pieces(double w, const RouletteEps& c) {
  std::array<std::array<double, 2>, 3> p{};
  roulette_left_end(w, c, p[0][0], p[0][1]);
  roulette_middle(w, c, p[1][0], p[1][1]);
  double a1, a2;
  roulette_left_end(1.0 - w, c, a1, a2);
  p[2] = {c.eps - a1, (c.eps - 2.0 * a1) + a2};
  return p;
}

// E[R(r, w)] and E[R(r, w)^2] for r ~ U(0, 1), eps in (0, 1/2]: exactly 0 at w <= 0 and 1 at w >= 1
// (R is constant there: the kept sum's variance is exactly 0); (w, w) for a vanishing eps.
inline void roulette_moments_at(double w, const RouletteEps& c, double& e1, double& e2) {
  const auto p = roulette_moment_pieces(w, c);
  double s1 = (p[0][0] + p[1][0]) + p[2][0], s2 = (p[0][1] + p[1][1]) + p[2][1];
  s1 = c.vanishing ? w : s1;
  s2 = c.vanishing ? w : s2;
  e1 = w > 0.0 ? (w < 1.0 ? s1 : 1.0) : 0.0;
  e2 = w > 0.0 ? (w < 1.0 ? s2 : 1.0) : 0.0;
}

// E[R(r, weight)] and E[R(r, weight)^2] by Gauss-Kronrod quadrature (31 points) between R's
// breakpoints: the reference the closed form blend_detail::roulette_moments is tested against (about
// 300 evaluations of R; not used for sampling).
std::array<double, 2> roulette_moments_quadrature(double weight, double eps);

}  // namespace glintlab::blend_detail

namespace glintlab::detail {

// The normal-sum rows of the mollified roulette (levels of more than 64 facets), a block at a time:
// for each level j whose first[j] is set and each row r < m,
//   weight = j == 0 ? 1 - w_lod[r w_step] : w_lod[r w_step],
//   (mom0[j][r], mom1[j][r]) = roulette_moments(weight, eps),
//   level[j][r] = the rule's normal_kept(k[j][r], moments, first[j][2 r]) when its normal quantile is
//   central (|u - 1/2| <= 0.425) or not needed (sd = 0), else NaN (the caller evaluates those rows
//   with the scalar code, from the moments given).
// Bit for bit the scalar rule's values for rows with k > 0; rows the caller routes elsewhere
// (k <= 64) are computed and ignored. w_step = 0: one weight for every row (its moments once).
// Also: tail[j][0 .. tails[j]) the rows r (ascending) whose level[j][r] is NaN (room for m + 16),
// and explicit_rows, whether some row of such a level has a count that is neither <= 0 nor above
// kRouletteExplicitFacets (explicit facets, or NaN).
inline constexpr double kRouletteExplicitFacets = 64;
struct RouletteRows {
  std::size_t m = 0;
  const double* w_lod = nullptr;
  std::size_t w_step = 1;
  std::array<const double*, 2> k{nullptr, nullptr};
  std::array<const double*, 2> first{nullptr, nullptr};
  double eps = 0.1;
  std::array<double*, 2> level{nullptr, nullptr}, mom0{nullptr, nullptr}, mom1{nullptr, nullptr};
  std::array<std::uint32_t*, 2> tail{nullptr, nullptr};
  std::array<std::size_t, 2> tails{0, 0};
  bool explicit_rows = false;
};
void roulette_normal_rows(RouletteRows& rows);  // at detail::simd_level()
void roulette_normal_rows_avx512(RouletteRows& rows);
void roulette_normal_rows_avx2(RouletteRows& rows);
void roulette_normal_rows_portable(RouletteRows& rows);

// out[i] = normal::quantile(u[i]) where |u[i] - 1/2| <= 0.425 (AS 241's central region: the same
// operations, so the same bits), NaN elsewhere; at detail::simd_level().
void normal_quantile_central(const double* u, std::size_t count, double* out);
void normal_quantile_central_avx512(const double* u, std::size_t count, double* out);
void normal_quantile_central_avx2(const double* u, std::size_t count, double* out);
void normal_quantile_central_portable(const double* u, std::size_t count, double* out);

// out[i] = normal::quantile(u[i]) bit for bit, given log_tail[i] = std::log(u[i] < 1/2 ? u[i] : 1 - u[i])
// as quantile computes it (any value where u[i] is central or outside (0, 1): unused there). The
// caller's scalar logarithm keeps the bits; the rest (the tails' rational functions) runs in vectors.
void normal_quantile_with_log(const double* u, const double* log_tail, std::size_t count, double* out);
void normal_quantile_with_log_avx512(const double* u, const double* log_tail, std::size_t count, double* out);
void normal_quantile_with_log_avx2(const double* u, const double* log_tail, std::size_t count, double* out);
void normal_quantile_with_log_portable(const double* u, const double* log_tail, std::size_t count, double* out);
// out[i] = the roulette's normal_kept(k[i], {mom0[i], mom1[i]}, u[i]) with the quantile as above.
void roulette_normal_kept(const double* k, const double* mom0, const double* mom1, const double* u,
                          const double* log_tail, std::size_t count, double* out);
void roulette_normal_kept_avx512(const double* k, const double* mom0, const double* mom1, const double* u,
                                 const double* log_tail, std::size_t count, double* out);
void roulette_normal_kept_avx2(const double* k, const double* mom0, const double* mom1, const double* u,
                               const double* log_tail, std::size_t count, double* out);
void roulette_normal_kept_portable(const double* k, const double* mom0, const double* mom1, const double* u,
                                   const double* log_tail, std::size_t count, double* out);

}  // namespace glintlab::detail
