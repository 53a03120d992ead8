// Private helper of binomial.cpp: the exact binomial sampler's common first steps as branch-free
// loops across samples (binomial_simd_body.inc), compiled once per instruction set
// (binomial_simd_avx512.cpp, binomial_simd_avx2.cpp) and chosen by detail::simd_level(); the
// portable level keeps the scalar code (see binomial.cpp). Each sample has its own uniforms (its
// own counter-based stream), so evaluating many samples side by side changes nothing; every kernel
// repeats the scalar Sampler's IEEE operations in the scalar code's order (no FMA contraction:
// -ffp-contract=off) and flags the samples it cannot finish, which the caller completes with the
// scalar code.
#pragma once

#include <cstddef>
#include <cstdint>

namespace glintlab::detail {

// Below this mean (of min(p, 1 - p) floor(n)) the Sampler inverts (inversion.hpp), from it on it
// runs BTRD; see binomial.cpp.
inline constexpr double kBinomialInversionMaxMean = 30.0;

// Constants of BTRD's step 1 for one (n, p), as binomial::Sampler holds them.
struct BtrdStep1 {
  double m;     // integer part of n
  double g;     // probability of the fractional facet (0: none)
  double flip;  // 1: K = m - BTRD(m, 1 - p)
  double urvr;  // step 1 accepts v <= urvr
  double inv_vr;
  double two_a;  // 2 a
  double b, c;
};

// Rows of one (n, p) in BTRD's regime; u = [u0, u1] per row (the first Philox block).
// out[r] = the draw when BTRD's step 1 accepts u0 (then the fractional facet takes u1), and
// redo[r] = 1.0 where it does not (out[r] is then meaningless).
void binomial_btrd_rows_avx512(const BtrdStep1& s, const double* u, std::size_t rows, double* out, double* redo);
void binomial_btrd_rows_avx2(const BtrdStep1& s, const double* u, std::size_t rows, double* out, double* redo);

// BTRD's other steps (2-3.2) of the first attempt, for the rows step 1 did not accept, compacted:
// v[j], u1[j] their two uniforms. Constants as binomial::Sampler holds them.
struct BtrdAttempt {
  double m, mode, alpha, a, b, c, vr, inv_vr, r, nr, npq;
};
// Outputs per row: k[j] the attempt's K (before the reflection), and state[j]:
//   0  accepted (step 3.1's exact ratio test, |K - mode| <= 15);
//   1  rejected (K outside [0, m], or step 3.1 rejects): the next attempt starts at the second block;
//   2  step 3.2's squeeze decides: accept iff log(w[j]) < lo[j], reject iff log(w[j]) > hi[j],
//      otherwise (or on NaN) the scalar Sampler decides.
void binomial_btrd_attempt_avx512(const BtrdAttempt& s, const double* v, const double* u1, std::size_t count, double* k,
                                  double* w, double* lo, double* hi, double* state);
void binomial_btrd_attempt_avx2(const BtrdAttempt& s, const double* v, const double* u1, std::size_t count, double* k,
                                double* w, double* lo, double* hi, double* state);

// The rows with redo[r] != 0 gathered densely: row_of[j], v[j] = u[2 row], u1[j] = u[2 row + 1];
// returns their number. The AVX-512 version writes whole vectors: the three outputs need room for
// 7 elements past rows.
std::size_t binomial_compact_avx512(const double* redo, const double* u, std::size_t rows, std::uint32_t* row_of,
                                    double* v, double* u1);

// Pixels with their own (n, p), in three kernels.
// prepare: neg_pp[i] = -min(p, 1 - p) (as the Sampler reflects p), m[i] = floor(n[i]), for the
// caller's vector log1p and exp of P(K = 0) = exp(m log1p(-min(p, 1 - p))).
void binomial_pixels_prepare_avx512(const double* n, const double* p, std::size_t count, double* neg_pp, double* m);
void binomial_pixels_prepare_avx2(const double* n, const double* p, std::size_t count, double* neg_pp, double* m);
// pixels: the Sampler's setup and the first step of its method. f0[i] approximates P(K = 0) within
// a relative 1e-12 of the C library's value (the caller's vector exp and log1p); the kernel decides
// K = 0 only when u0 lies below f0 by more than kInversionGuard, so the exact value decides alike.
// out[i] the draw; redo[i] = 0 done, 1 for the scalar Sampler (invalid parameters included, so
// that it reports them), 3 for BTRD's steps 2-3.2 (step 1 did not accept u0), 2 for the
// inversion's search past K = 0 (u0 above f0 by more than the guard), whose recursion f(k) = f(k - 1) (a / k - s) up to
// k = bound is given in inv_a, inv_s, inv_bound (the Sampler's values).
void binomial_pixels_avx512(const double* n, const double* p, const double* u, const double* f0, std::size_t count,
                            double* out, double* redo, double* inv_a, double* inv_s, double* inv_bound);
void binomial_pixels_avx2(const double* n, const double* p, const double* u, const double* f0, std::size_t count,
                          double* out, double* redo, double* inv_a, double* inv_s, double* inv_bound);
// pixels attempt: binomial_btrd_attempt_* for compacted pixels in BTRD's regime, each with its own
// (n[j], p[j]) (the Sampler's constants computed per pixel).
void binomial_pixels_attempt_avx512(const double* n, const double* p, const double* v, const double* u1,
                                    std::size_t count, double* k, double* w, double* lo, double* hi, double* state);
void binomial_pixels_attempt_avx2(const double* n, const double* p, const double* v, const double* u1,
                                  std::size_t count, double* k, double* w, double* lo, double* hi, double* state);
// inversion steps: up to 8 more steps of the inversion's search (SmallMeanInversion) for compacted
// pixels at (k, f = f(k), c = c_k) with u0 > c_k proved, on cumulative sums continued from the
// vector f0 and compared with the guard band. state[j] = 0: K = k[j] proved; 1: a comparison fell
// within the band or k passed the bound (the scalar Sampler decides); 2: not settled yet.
void binomial_inversion_steps_avx512(const double* u0, const double* a, const double* s, const double* bound,
                                     std::size_t count, double* k, double* f, double* c, double* state);
void binomial_inversion_steps_avx2(const double* u0, const double* a, const double* s, const double* bound,
                                   std::size_t count, double* k, double* f, double* c, double* state);

// The relative guard band around the vector P(K = 0) (and the cumulative sums continued from it):
// 2^-30, over four orders of magnitude wider than the difference between SLEEF's and the C
// library's exp(m log1p(-p)) (a few ulps times |m log1p(-p)| <= 42) plus the rounding of the
// recursion's few hundred steps, and far too narrow to matter for speed.
inline constexpr double kInversionGuard = 0x1.0p-30;

}  // namespace glintlab::detail
