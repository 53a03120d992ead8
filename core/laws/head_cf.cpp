// Law "head_cf": glintlab's constant-time law (issue: beat the gated Gaussian's worst case).
//
// Derivation. Count the rarer outcome, Y ~ Binomial(m, pt) with pt = min(p, 1 - p) and m = floor(n)
// (K = Y, or m - Y when p > 1/2, so p -> 1 behaves like p -> 0, where DB23's gate reaches TV 0.5).
// Invert its CDF with one uniform u0, exactly where the law is most discrete and skewed and
// approximately in the bulk:
//   - the head: P(Y = 0), P(Y = 1), P(Y = 2) in closed form (q^m through exp(m log1p(-pt)), then the
//     ratio recurrence), so u0 <= F(2) returns the exact count;
//   - the tail: the continuity-corrected normal quantile with a one-term Cornish-Fisher skewness
//     correction, Y = ceil(mu + sd (z + g (z^2 - 1) / 6) - 1/2), z = Phi^-1(u0), g = (1 - 2 pt)/sd the
//     binomial's skewness, clamped to [3, m]. z is clamped to the increasing branch of the cubic-free
//     quadratic (z >= -3/g), which keeps Y monotone in u0.
// The fractional facet of a non-integer n (the stratified rule) is an independent Bernoulli(f p)
// drawn with u1. Cost: exp, log1p, sqrt, one Phi^-1 and a few products: constant in n, like gated.
//
// Exact law: the head is exact; in the tail Y <= k iff z <= z_k, the increasing root of
// mu + sd (z + g (z^2 - 1)/6) - 1/2 = k, so P(Y <= k) = max(F(2), Phi(z_k)) for 3 <= k < m (F(2) when
// no root: the tail never reaches k); then the fractional facet by convolution.
#include <algorithm>
#include <cmath>

#include "glintlab/base/errors.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/detail/pixel_blocks.hpp"
#include "glintlab/stats/normal.hpp"
#include "glintlab/stats/step_inversion.hpp"

namespace glintlab {
namespace {

template <class T>
struct Head {
  T m, pt, f0, f1, f2;  // F(0), F(1), F(2) of Binomial(m, pt)
  Head(T n, T p) : m(std::floor(n)), pt(p < T(0.5) ? p : T(1) - p) {
    const T qt = T(1) - pt;
    const T p0 = std::exp(m * std::log1p(-pt));
    const T p1 = m >= T(1) ? p0 * m * pt / qt : T(0);
    const T p2 = m >= T(2) ? p1 * (m - T(1)) * pt / (T(2) * qt) : T(0);
    f0 = p0;
    f1 = p0 + p1;
    f2 = p0 + p1 + p2;
  }
};

// The exact CDF of Y (see the header comment) and where its tail steps sit in z.
struct HeadCfCdf {
  Head<double> h;
  double m, mu, sd;
  HeadCfCdf(double n, double p) : h(n, p), m(h.m), mu(m * h.pt), sd(std::sqrt(mu * (1 - h.pt))) {}
  // z_k: Y <= k iff z <= z_k in the tail (NaN when the tail never reaches k).
  double z_step(double k) const {
    const double g = (1 - 2 * h.pt) / sd, a = g / 6, c = (k + 0.5 - mu) / sd;
    // a z^2 + z - a - c = 0, increasing root; stable form for a -> 0.
    const double disc = 1 + 4 * a * (a + c);
    if (disc < 0) return NAN;
    return 2 * (a + c) / (1 + std::sqrt(disc));
  }
  double operator()(double k) const {
    if (k >= m) return 1.0;
    if (k < 0) return 0.0;
    if (k == 0) return h.f0;
    if (k == 1) return h.f1;
    if (k == 2 || !(sd > 0)) return h.f2;
    const double zk = z_step(k);
    return std::isnan(zk) ? h.f2 : std::max(h.f2, normal::cdf(zk));
  }
  // The tail map at z (clamped to the increasing branch, as eval does).
  double tail_at(double z) const {
    if (!(sd > 0)) return mu;
    const double g = (1 - 2 * h.pt) / sd;
    if (g > 0 && z < -3 / g) z = -3 / g;
    return std::ceil(mu + sd * (z + g * (z * z - 1) / 6) - 0.5);
  }
  // The range of Y the law's uniforms (in [2^-53, 1 - 2^-53], |z| <= 8.3) can reach, padded.
  std::pair<double, double> reach() const {
    const double lo = h.f2 >= 1e-17 ? 0.0 : std::clamp(tail_at(-8.3) - 2, 0.0, m);
    const double hi = std::clamp(tail_at(8.3) + 2, std::min(m, 2.0), m);
    return {lo, hi};
  }
};

class HeadCfLaw final : public detail::KernelLaw<HeadCfLaw> {
 public:
  std::string name() const override { return "head_cf"; }
  int n_uniforms() const override { return 2; }

  // The per-(n, p) constants (the head), then the row (detail::KernelLaw: eval is Constants(n, p)(u)).
  template <class T>
  struct Constants {
    Head<T> h;
    T n, p;
    Constants(T n_, T p_) : h(n_, p_), n(n_), p(p_) {}
    T operator()(const T* u) const {
      T y;
      if (u[0] <= h.f0)
        y = T(0);
      else if (u[0] <= h.f1)
        y = T(1);
      else if (u[0] <= h.f2)
        y = T(2);
      else {
        const T mu = h.m * h.pt, sd = std::sqrt(mu * (T(1) - h.pt));
        if (sd > T(0)) {
          const T g = (T(1) - T(2) * h.pt) / sd;
          T z = normal::quantile(u[0]);
          if (g > T(0) && z < T(-3) / g) z = T(-3) / g;  // stay on the increasing branch
          // g = 0 (p = 1/2): no correction (and no 0 * inf at u = 1).
          const T cf = g > T(0) ? z + g * (z * z - T(1)) / T(6) : z;
          y = std::ceil(mu + sd * cf - T(0.5));
        } else {
          y = mu;
        }
        y = y < T(3) ? T(3) : y;
      }
      y = y > h.m ? h.m : y;
      const T whole = p <= T(0.5) ? y : h.m - y;
      const T frac_p = (n - h.m) * p;  // the stratified rule's fractional facet
      return whole + (u[1] < frac_p ? T(1) : T(0));
    }
  };
  template <class T>
  Constants<T> constants(T n, T p) const {
    return Constants<T>(n, p);
  }

  // Pixels with their own (n, p): the vector block pass at the CPU's ISA (head_cf_pixels_body.inc: the
  // head's F(0), F(1), F(2) and the quantile's log by SLEEF, the rest as eval's expressions), then eval
  // wherever it flagged a pixel as too close to a decision to be sure (u0 within a relative 1e-11 of
  // F(0), F(1) or F(2); the tail's ceil argument within 1e-11 of its magnitude from an integer): bit for
  // bit eval. CPUs without AVX2 and FMA evaluate every pixel.
  void evaluate_pixels(const double* n, const double* p, const double* u, std::size_t count,
                       double* out) const override {
    if (!detail::run_pixel_blocks(
            detail::head_cf_pixels_block_avx512, detail::head_cf_pixels_block_avx2, n, p, u, count, out,
            [this](double nv, double pv, const double* row) { return eval<double>(nv, pv, row); }))
      KernelLaw::evaluate_pixels(n, p, u, count, out);
  }

  // Many rows at one (n, p): Y by table inversion of its exact CDF (the thresholds pmf() uses), with
  // guard bands so that every answer equals eval's; the fractional facet as in eval.
  std::optional<detail::RowTable> table(double n, double p, std::size_t rows) const {
    const HeadCfCdf cdf(n, p);
    const auto [lo, hi] = cdf.reach();
    if (hi - lo > static_cast<double>(std::max<std::size_t>(rows / 4, 64)) || hi - lo > (1 << 16) ||
        hi >= 0x1p53)  // k += 1 below would stop advancing
      return std::nullopt;
    std::vector<double> t, guard;
    const double g = cdf.sd > 0 ? (1 - 2 * cdf.h.pt) / cdf.sd : 0.0;
    double covered = 0;
    for (double k = lo; k < hi; k += 1) {  // Y > k iff u > cdf(k)
      t.push_back(cdf(k));
      double band = 64 * 2.220446049250313e-16;  // head: eval compares with the same f0, f1, f2
      if (k >= 2 && cdf.sd > 0) {
        const double zk = cdf.z_step(k);
        const double slope = std::isnan(zk) ? 1e-6 : std::max(1e-6, 1 + g * zk / 3);
        const double z = std::isnan(zk) ? 0.0 : zk;
        band = StepInversion::gaussian_guard(t.back(), z, cdf.sd, slope,
                                             std::abs(cdf.mu) + cdf.sd * (std::abs(z) + g * z * z) + 1);
      }
      guard.push_back(band);
      covered += 2 * band;
    }
    if (covered > 1e-3) return std::nullopt;
    const bool flip = p > 0.5;
    const double m = cdf.m, frac_p = (n - m) * p;
    StepInversion steps(std::move(t), std::move(guard), lo, lo == 0, hi == m);
    // eval's (flip ? m - y : y) + [u1 < frac_p] as the table's affine map (s = -1: m + (-y) = m - y).
    StepInversion::Affine f;
    f.a = flip ? m : 0.0;
    f.s = flip ? -1.0 : 1.0;
    f.extra_col = 1;
    f.extra_below = frac_p;
    return detail::RowTable{std::move(steps), f, 0};
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const HeadCfCdf cdf(n, p);
    const double m = cdf.m;
    const auto [lo_k, hi_k] = cdf.reach();
    // Above 2^53 consecutive integers are not representable: k += 1 below would stop advancing.
    if (hi_k >= 0x1p53)
      throw_invalid_message("head_cf.pmf: n = " + format_value(n) + ", p = " + format_value(p) +
                            " puts the support at counts above 2^53 (9.007e15), where doubles no longer "
                            "hold consecutive integers; expected n p below 9e15");
    if (hi_k - lo_k + 2 > static_cast<double>(max_support))
      throw_invalid_message("head_cf.pmf: n = " + format_value(n) + ", p = " + format_value(p) +
                            " needs more than max_support = " + std::to_string(max_support) + " support points");
    std::vector<double> ys, py;
    double prev = cdf(lo_k - 1);
    const bool cut_below = prev > 0;
    for (double k = lo_k; k <= hi_k; k += 1) {
      const double c = cdf(k);
      ys.push_back(k);
      py.push_back(std::max(0.0, c - prev));
      prev = c;
    }
    const bool cut_above = prev < 1;
    // K = Y (or m - Y) plus the fractional facet.
    std::vector<double> ks, pk;
    const bool flip = p > 0.5;
    const double gp = (n - m) * p;
    std::vector<double> base(ys.size());
    for (std::size_t i = 0; i < ys.size(); ++i) base[i] = flip ? m - ys[i] : ys[i];
    if (flip) {
      std::reverse(base.begin(), base.end());
      std::reverse(py.begin(), py.end());
    }
    for (std::size_t i = 0; i <= base.size(); ++i) {
      // value base[0] + i collects (1 - gp) P(base = v) + gp P(base = v - 1); base is contiguous.
      const double here = i < base.size() ? py[i] : 0.0, below = i > 0 ? py[i - 1] : 0.0;
      const double prob = (1 - gp) * here + gp * below;
      if (i == base.size() && gp == 0) break;
      ks.push_back(base.front() + static_cast<double>(i));
      pk.push_back(prob);
    }
    // Drop exact zeros at the ends (a strict support), keep the trimming flags honest.
    while (pk.size() > 1 && pk.back() == 0) {
      pk.pop_back();
      ks.pop_back();
    }
    std::size_t first = 0;
    while (first + 1 < pk.size() && pk[first] == 0) ++first;
    ks.erase(ks.begin(), ks.begin() + static_cast<std::ptrdiff_t>(first));
    pk.erase(pk.begin(), pk.begin() + static_cast<std::ptrdiff_t>(first));
    const bool below = flip ? cut_above : cut_below, above = flip ? cut_below : cut_above;
    return Distribution::with_trimmed_tails(std::move(ks), std::move(pk), below, above);
  }
};

const bool registered = register_parameterless_law<HeadCfLaw>(
    "head_cf", "glintlab: exact head (K <= 2) + Cornish-Fisher tail of the rarer outcome; constant time",
    {.output = LawOutput::kInteger,
     .support = SupportBound::kBoundedByN,
     .constant_time = true,
     .regime = "the whole (n, p) plane: exact where the count is small and skewed, Cornish-Fisher in the bulk",
     .cost = "constant: exp, log1p, sqrt and one Phi^-1",
     .study_variants = {LawParams{}},
     .bench_variants = {LawParams{}},
     .test_variants = {LawParams{}},
     .bounds = {{.metrics = {"tv", "mean_rel_err"}, .reason = "glintlab's law over the whole standard grid"}},
     .shader = "head_cf"});

}  // namespace
}  // namespace glintlab
