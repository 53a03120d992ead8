// Law "gated": DB23's gated Gaussian (eq. 16-18) as intended.
//   P1 = 1 - (1 - p)^n                       (eq. 16; computed as -expm1(n log1p(-p)))
//   mu = (n - 1) p, sigma = sqrt((n - 1) p (1 - p))   (eq. 17: the Gaussian of Binomial(n - 1, p))
//   K = [theta0 < P1] (1 + floor(mu + sigma Phi^-1(theta1)))   (eq. 18)
// The paper prints H(theta0 - P1), which gates with probability 1 - P1; the intent is theta0 < P1
// (so that P(K = 0) = (1 - p)^n, as for the binomial). See docs/math/laws.md#law-gated.
//
// Policy where the paper is silent: floor(G) is clamped to [0, ceil(n) - 1], so that a gated count
// is at least 1 and K never exceeds ceil(n) (the stratified binomial's top). For n < 1, n - 1 is
// replaced by 0 (mu = sigma = 0: K = Bernoulli(P1)). The mass the clamp moves is
// P1 Phi(-mu / sigma) at the bottom, visible in the exact pmf below (tests measure it).
//
// Exact law: P(K = 0) = 1 - P1; P(K = 1 + j) = P1 P(clamp(floor(G), 0, ceil(n) - 1) = j).
#include <algorithm>
#include <cmath>

#include "../src/pixel_blocks.hpp"
#include "../src/simd_math.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/normal.hpp"
#include "glintlab/step_inversion.hpp"

namespace glintlab {
namespace {

// The per-(n, p) constants of eq. 16-17, so that a batch computes them once (same expressions).
template <class T>
struct GatedConstants {
  T p1, mu, sigma, top;
  GatedConstants(T n, T p) {
    // n = 0 facets never reflect; the guard also avoids 0 * log1p(-1) = 0 * -inf = NaN at p = 1.
    p1 = n > T(0) ? -std::expm1(n * std::log1p(-p)) : T(0);
    const T m = n > T(1) ? n - T(1) : T(0);
    mu = m * p;
    sigma = std::sqrt(mu * (T(1) - p));
    top = std::ceil(n) - T(1);
  }
  // clamp(floor(G), 0, top) from theta1.
  T gaussian_count(T theta1) const {
    const T g = sigma > T(0) ? mu + sigma * normal::quantile(theta1) : mu;
    const T j = std::floor(g);
    return j < T(0) ? T(0) : (j > top ? top : j);
  }
  // K from (theta0, theta1): eval's expression on constants computed once.
  T operator()(const T* u) const { return u[0] < p1 ? T(1) + gaussian_count(u[1]) : T(0); }
};

class GatedLaw final : public detail::KernelLaw<GatedLaw> {
 public:
  std::string name() const override { return "gated"; }
  int n_uniforms() const override { return 2; }

  template <class T>
  T eval(T n, T p, const T* u) const {
    const GatedConstants<T> c(n, p);
    if (!(u[0] < c.p1)) return T(0);
    return T(1) + c.gaussian_count(u[1]);
  }

  // Rows at one (n, p): the constants once (detail::KernelLaw), or the table below.
  template <class T>
  GatedConstants<T> constants(T n, T p) const {
    return GatedConstants<T>(n, p);
  }

  // Pixels with their own (n, p): log1p, expm1 and the quantile's log by SLEEF over the block, the
  // rest as eval. Bit-identical to eval: the gate is decided from the vector P1 only when u0 is
  // farther from it than 1e-11 P1 (the two P1 differ by a few ulps: |n log1p(-p)| e^x / (1 - e^x) <= 1
  // keeps expm1's relative error at its own), the Gaussian count only when its argument is farther
  // than 1e-11 of its magnitude from an integer (the quantile's central region is eval's own
  // expressions, exact); any other pixel (about 1e-11 of them) is recomputed by eval.
  void evaluate_pixels(const double* n, const double* p, const double* u, std::size_t count,
                       double* out) const override {
    constexpr std::size_t kB = 256;
    // The whole block at the CPU's ISA (gated_pixels_body.inc), then eval where flagged.
    if (detail::run_pixel_blocks(detail::gated_pixels_block_avx512, detail::gated_pixels_block_avx2, n, p, u, count,
                                 out,
                                 [this](double nv, double pv, const double* row) { return eval<double>(nv, pv, row); }))
      return;
    alignas(64) double a[kB], e[kB], lt[kB];
    for (std::size_t s = 0; s < count; s += kB) {
      const std::size_t m = std::min(kB, count - s);
      const double *nn = n + s, *pp = p + s, *uu = u + 2 * s;
      double* oo = out + s;
      for (std::size_t i = 0; i < m; ++i) a[i] = -pp[i];
      detail::vec_log1p(a, e, m);
      for (std::size_t i = 0; i < m; ++i) a[i] = nn[i] * e[i];
      detail::vec_expm1(a, e, m);  // e = -P1
      for (std::size_t i = 0; i < m; ++i) {
        const double v = uu[2 * i + 1];
        a[i] = v < 0.5 ? v : 1.0 - v;  // quantile's min(u, 1 - u), as it computes it
      }
      detail::vec_log(a, lt, m);
      if (const int level = detail::simd_level(); level >= 1) {
        // The rest as one vectorized branch-free pass (gated_pixels_body.inc), then eval where flagged.
        alignas(64) double redo[kB];
        if (level >= 2)
          detail::gated_pixels_avx512(nn, pp, uu, e, lt, m, oo, redo);
        else
          detail::gated_pixels_avx2(nn, pp, uu, e, lt, m, oo, redo);
        for (std::size_t i = 0; i < m; ++i)
          if (redo[i] != 0.0) oo[i] = eval<double>(nn[i], pp[i], uu + 2 * i);
        continue;
      }
      for (std::size_t i = 0; i < m; ++i) {
        const double nv = nn[i], pv = pp[i], u0 = uu[2 * i], u1 = uu[2 * i + 1];
        const double* row = uu + 2 * i;
        if (!(u0 > 0.0 && u0 < 1.0 && u1 > 0.0 && u1 < 1.0)) {
          oo[i] = eval<double>(nv, pv, row);
          continue;
        }
        if (!(nv > 0.0)) {
          oo[i] = 0.0;
          continue;
        }  // P1 = 0: never gated (eval's guard)
        const double p1 = -e[i];
        if (!(std::abs(u0 - p1) > 1e-11 * std::abs(p1))) {
          oo[i] = eval<double>(nv, pv, row);
          continue;
        }
        if (!(u0 < p1)) {
          oo[i] = 0.0;
          continue;
        }
        const double mm = nv > 1.0 ? nv - 1.0 : 0.0, mu = mm * pv, sigma = std::sqrt(mu * (1.0 - pv));
        const double top = std::ceil(nv) - 1.0;
        double g = mu;
        if (sigma > 0.0) {
          bool central;
          const double z = normal::quantile_given_log(u1, lt[i], central);
          g = mu + sigma * z;
          if (!central) {
            const double f = g - std::floor(g), tol = 1e-11 * (std::abs(mu) + sigma * (std::abs(z) + 1.0));
            if (!(f > tol && 1.0 - f > tol)) {
              oo[i] = eval<double>(nv, pv, row);
              continue;
            }
          }
        }
        const double j = std::floor(g);
        oo[i] = 1.0 + (j < 0.0 ? 0.0 : (j > top ? top : j));
      }
    }
  }

  // Many rows at one (n, p) (a batch, a blend's level at one footprint area): the Gaussian count by
  // table inversion, the table lookups as vector gathers and the gate as a select; the same values
  // as eval (the table's construction guarantees it).
  std::optional<detail::RowTable> table(double n, double p, std::size_t rows) const {
    const GatedConstants<double> c(n, p);
    auto steps = floor_gaussian_steps(c.mu, c.sigma, 0.0, c.top, std::max<std::size_t>(rows / 4, 64));
    if (!steps) return std::nullopt;
    StepInversion::Affine f;
    f.a = 1;
    f.gate_col = 0;
    f.gate_below = c.p1;
    return detail::RowTable{std::move(*steps), f, 1};
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const double p1 = n > 0 ? -std::expm1(n * std::log1p(-p)) : 0.0;  // as GatedConstants
    const double m = n > 1 ? n - 1 : 0.0, mu = m * p, sigma = std::sqrt(mu * (1 - p));
    std::vector<double> ks{0.0}, ps{1.0 - p1};
    bool trimmed_above = false;
    if (p1 > 0) {
      if (sigma > 0) {
        auto law = normal::discretized(mu, sigma, std::ceil(n) - 1, 0.0, max_support, "gated.pmf");
        // Below the gated part's first point lies trimmed mass < 1e-16 that belongs to K >= 1:
        // fold it into K = 1 by starting at j = 0 when trimmed (it is < 1e-16 of P1).
        for (std::size_t i = 0; i < law.support.size(); ++i) {
          ks.push_back(1 + law.support[i]);
          ps.push_back(p1 * law.probs[i]);
        }
        trimmed_above = law.trimmed_above;
      } else {
        const double one = std::clamp(std::floor(mu), 0.0, std::ceil(n) - 1);
        ks.push_back(1 + one);
        ps.push_back(p1);
      }
    }
    if (ps.front() == 0.0 && ks.size() > 1) {  // p1 = 1: no zero count
      ks.erase(ks.begin());
      ps.erase(ps.begin());
    }
    // Gaps (support starting above 1) carry probability zero exactly: keep the support strict.
    return Distribution::with_trimmed_tails(std::move(ks), std::move(ps), false, trimmed_above);
  }
};

const bool registered = register_parameterless_law<GatedLaw>(
    "gated", "DB23 gated Gaussian (eq. 16-18, gate theta0 < P1), floor(G) clamped to [0, ceil(n)-1]",
    {.output = LawOutput::kInteger,
     .support = SupportBound::kBoundedByN,
     .constant_time = true,
     .regime = "p <= 1/2 (DB23's renderer); near p = 1 the gate fails by design",
     .cost = "constant: exp, log1p, sqrt and one Phi^-1",
     .study_variants = {LawParams{}},
     .bench_variants = {LawParams{}},
     .test_variants = {LawParams{}},
     .bounds = {{.regime = {{"p_range", {0, 0.5}}},
                 .metrics = {"tv", "mean_rel_err"},
                 .reason = "p <= 1/2 (near p = 1 the gate fails by design, TV 0.91)"}}});

}  // namespace
}  // namespace glintlab
