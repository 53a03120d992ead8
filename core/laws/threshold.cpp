// Law "threshold": WWH18's filtered model. Where the expected count n p exceeds the threshold T
// (default 16, as in WWH18), the count is replaced by its mean n p (deterministic, real-valued:
// zero variance); below, the facets are counted explicitly: K is the exact (stratified) binomial,
// drawn by inversion of one uniform. Parameter: T > 0.
//
// Exact law: a point mass at n p above T; the binomial below.
// The inversion runs in the evaluation precision: cumulative sums of the stratified binomial's pmf
// (recurrence from P(K = 0)), so float32 shows where single precision breaks (e.g. (1 - p)^n
// underflowing for p near 1).
#include <cmath>

#include "glintlab/base/errors.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"

namespace glintlab {
namespace {

// WWH18's threshold, shared by the factory's default and the declared bound domain.
constexpr double kDefaultThreshold = 16.0;

class ThresholdLaw final : public detail::KernelLaw<ThresholdLaw> {
 public:
  explicit ThresholdLaw(double t) : t_(t) {}
  std::string name() const override { return "threshold"; }
  LawParams params() const override { return {{"T", t_}}; }
  int n_uniforms() const override { return 1; }

  template <class T>
  T eval(T n, T p, const T* u) const {
    const T mean = n * p;
    if (mean > T(t_)) return mean;
    // Stratified binomial n = m + f: P(k) = (1 - g) b(k) + g b(k - 1), g = f p, b = Binomial(m, p).
    if (p <= T(0) || n <= T(0)) return T(0);
    const T m = std::floor(n), g = (n - m) * p, top = g > T(0) ? m + T(1) : m;
    if (p >= T(1)) return u[0] < g || g == T(0) ? top : m;  // all whole facets reflect
    const T s = p / (T(1) - p);
    T b_prev = T(0), b = std::exp(m * std::log1p(-p)), c = T(0);
    // The search is bounded like the exact sampler (mean + 15 sd + 30), then clamps.
    const T bound = std::fmin(top, std::ceil(mean + T(15) * std::sqrt(mean) + T(30)));
    for (T k = 0; k <= bound; k += T(1)) {
      c += (T(1) - g) * b + g * b_prev;
      if (u[0] <= c) return k;
      b_prev = b;
      b *= (m - k) / (k + T(1)) * s;  // b(k + 1) / b(k)
    }
    return bound;
  }

  // Expected steps of eval's CDF walk below T: it stops at k = K after K + 1 steps, and E[K] = n p
  // (the walk's cap at mean + 15 sd + 30 is almost never reached). Above T, and where eval returns
  // before the walk (p in {0, 1}, n = 0), no steps.
  double work_units(double n, double p) const override {
    const double mean = n * p;
    if (mean > t_ || p <= 0 || p >= 1 || n <= 0) return 0.0;
    return mean + 1;
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    if (n * p > t_) return Distribution({n * p}, {1.0});
    return binomial::distribution(n, p, max_support);
  }

 private:
  double t_;
};

const bool registered = register_law(
    {"threshold",
     "WWH18 filtered model: the mean n p above T=16, the exact binomial below",
     [](const LawParams& params) -> std::unique_ptr<CountingLaw> {
       ParamReader reader("threshold", params);
       const double t = reader.number("T", kDefaultThreshold);
       reader.finish();
       if (!(t > 0)) throw_invalid("law 'threshold'", "T", t, "a number > 0");
       return std::make_unique<ThresholdLaw>(t);
     },
     {.output = LawOutput::kReal,  // the mean n p above T
      .support = SupportBound::kBoundedByN,
      .constant_time = false,
      .regime = "n p <= T (the exact binomial); above T only the mean is right (no variance: a filtered look)",
      .cost = "constant above T; below, work_units = n p + 1 expected steps of the CDF walk",
      .study_variants = {LawParams{}},
      .bench_variants = {LawParams{}},
      // T = 2.5: a threshold that the test points cross on both sides.
      .test_variants = {LawParams{}, LawParams{{"T", 2.5}}},
      // Below and above T: the walk's cost, then none.
      .cost_points = {{100.0, 0.1}, {16.0, 0.1}, {1e3, 0.5}},
      .bounds = {{.regime = {{"np_range", {0, kDefaultThreshold}}},
                  .metrics = {"tv"},
                  .reason = "n p <= T: the exact binomial"},
                 {.metrics = {"mean_rel_err"}, .reason = "the mean n p is exact everywhere"}},
      // The mean n p is a point mass of the exact law, compared as it is (not rounded to a count).
      .bin_real = false}});

}  // namespace
}  // namespace glintlab
