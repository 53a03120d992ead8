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

#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/detail/pixel_blocks.hpp"
#include "glintlab/stats/normal.hpp"
#include "glintlab/stats/step_inversion.hpp"

namespace glintlab {
namespace {

// The per-(n, p) constants of eq. 16-17, computed here only: eval, the batch paths (once per batch) and
// the exact pmf all take them from this constructor. The vector per-pixel pass (gated_pixels_body.inc)
// only decides from its own cheap P1 where the decision is far from it, and leaves the rest to eval.
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

  // eval is constants(n, p)(u) (detail::KernelLaw); rows at one (n, p) compute the constants once, or
  // use the table below.
  template <class T>
  GatedConstants<T> constants(T n, T p) const {
    return GatedConstants<T>(n, p);
  }

  // Pixels with their own (n, p): the vector block pass at the CPU's ISA (gated_pixels_body.inc: the
  // gate from a cheap P1, the Gaussian count from eval's central quantile or a banded tail), then eval
  // wherever it flagged a pixel as too close to a decision to be sure: bit for bit eval. CPUs without
  // AVX2 and FMA evaluate every pixel.
  void evaluate_pixels(const double* n, const double* p, const double* u, std::size_t count,
                       double* out) const override {
    if (!detail::run_pixel_blocks(
            detail::gated_pixels_block_avx512, detail::gated_pixels_block_avx2, n, p, u, count, out,
            [this](double nv, double pv, const double* row) { return eval<double>(nv, pv, row); }))
      KernelLaw::evaluate_pixels(n, p, u, count, out);
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
    const GatedConstants<double> c(n, p);
    const double p1 = c.p1, mu = c.mu, sigma = c.sigma;
    std::vector<double> ks{0.0}, ps{1.0 - p1};
    bool trimmed_above = false;
    if (p1 > 0) {
      if (sigma > 0) {
        auto law = normal::discretized(mu, sigma, c.top, 0.0, max_support, "gated.pmf");
        // Below the gated part's first point lies trimmed mass < 1e-16 that belongs to K >= 1:
        // fold it into K = 1 by starting at j = 0 when trimmed (it is < 1e-16 of P1).
        for (std::size_t i = 0; i < law.support.size(); ++i) {
          ks.push_back(1 + law.support[i]);
          ps.push_back(p1 * law.probs[i]);
        }
        trimmed_above = law.trimmed_above;
      } else {
        const double one = std::clamp(std::floor(mu), 0.0, c.top);
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
