// Law "gaussian": the moment-matched normal approximation of the binomial (docs/math/laws.md#law-gaussian),
//   G = n p + sqrt(n p (1 - p)) Phi^-1(u),   K = clamp(floor(G) or round(G), 0, top),
// with top = ceil(n), the largest count of the stratified binomial (binomial.hpp) it approximates.
// Rounding "round" is floor(G + 1/2). Parameters: rounding = "floor" (default) | "round".
//
// Exact law: with thresholds t_k = k (floor) or k - 1/2 (round),
//   P(K = k) = P(t_k <= G < t_{k+1}) for 0 < k < top; the clamped ends take the tails:
//   P(K = 0) = P(G < t_1), P(K = top) = P(G >= t_top).
// Degenerate sd (p in {0, 1} or n = 0) gives K = clamp(rounding(n p)).
#include <cmath>

#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/normal.hpp"
#include "glintlab/stats/step_inversion.hpp"

namespace glintlab {
namespace {

class GaussianLaw final : public detail::KernelLaw<GaussianLaw> {
 public:
  explicit GaussianLaw(bool round) : round_(round) {}
  std::string name() const override { return "gaussian"; }
  LawParams params() const override { return {{"rounding", std::string(round_ ? "round" : "floor")}}; }
  int n_uniforms() const override { return 1; }

  // The per-(n, p) constants, then the row (detail::KernelLaw: eval is Constants(n, p)(u)).
  template <class T>
  struct Constants {
    T mean, sd, top;
    bool round;
    Constants(T n, T p, bool round_half_up)
        : mean(n * p), sd(std::sqrt(mean * (T(1) - p))), top(std::ceil(n)), round(round_half_up) {}
    T operator()(const T* u) const {
      // sd = 0 would make 0 * (+-inf) = NaN at u in {0, 1}: the law is then the point n p.
      const T g = sd > T(0) ? mean + sd * normal::quantile(u[0]) : mean;
      const T k = round ? std::floor(g + T(0.5)) : std::floor(g);
      return k < T(0) ? T(0) : (k > top ? top : k);  // clamp; +-inf map to the ends
    }
  };
  template <class T>
  Constants<T> constants(T n, T p) const {
    return Constants<T>(n, p, round_);
  }

  // Many rows at one (n, p): the count by table inversion (bit-identical to eval; see step_inversion).
  std::optional<detail::RowTable> table(double n, double p, std::size_t rows) const {
    const double mean = n * p, sd = std::sqrt(mean * (1.0 - p));
    auto steps = floor_gaussian_steps(mean, sd, round_ ? 0.5 : 0.0, std::ceil(n), std::max<std::size_t>(rows / 4, 64));
    if (!steps) return std::nullopt;
    return detail::RowTable{std::move(*steps), {}, 0};
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const double mean = n * p, sd = std::sqrt(mean * (1.0 - p));
    if (!(sd > 0)) {
      const double u = 0.5;
      return Distribution({eval<double>(n, p, &u)}, {1.0});
    }
    auto law = normal::discretized(mean, sd, std::ceil(n), round_ ? 0.5 : 0.0, max_support, "gaussian.pmf");
    return Distribution::with_trimmed_tails(std::move(law.support), std::move(law.probs), law.trimmed_below,
                                            law.trimmed_above);
  }

 private:
  bool round_;
};

const bool registered = register_law(
    {"gaussian",
     "moment-matched normal, floor or round (rounding=), clamped to [0, ceil(n)]",
     [](const LawParams& params) -> std::unique_ptr<CountingLaw> {
       ParamReader reader("gaussian", params);
       const bool round = reader.text("rounding", "floor", {"floor", "round"}) == "round";
       reader.finish();
       return std::make_unique<GaussianLaw>(round);
     },
     {.output = LawOutput::kInteger,
      .support = SupportBound::kBoundedByN,
      .constant_time = true,
      .regime = "the bulk: n p >= 10, p <= 1/2 (a normal cannot give the skewed small counts)",
      .cost = "constant: one Phi^-1",
      // Both roundings in the study (floor is the paper's, round the better one); the benchmark
      // times one, as both cost the same.
      .study_variants = {LawParams{{"rounding", std::string("floor")}}, LawParams{{"rounding", std::string("round")}}},
      .bench_variants = {LawParams{{"rounding", std::string("round")}}},
      .test_variants = {LawParams{{"rounding", std::string("floor")}}, LawParams{{"rounding", std::string("round")}}},
      .bounds = {{.regime = {{"p_range", {0, 0.5}}, {"np_range", {10, 1e300}}},
                  .metrics = {"tv", "mean_rel_err"},
                  .reason = "floored normal: meant for n p >= 10"},
                 {.params = {{"rounding", std::string("round")}},
                  .regime = {{"p_range", {0, 0.5}}, {"np_range", {10, 1e300}}},
                  .metrics = {"tv", "mean_rel_err"},
                  .reason = "rounded normal, n p >= 10"},
                 {.params = {{"rounding", std::string("round")}},
                  .regime = {{"p_range", {0, 0.5}}},
                  .metrics = {"tv"},
                  .reason = "rounded normal, whole lower half"}}}});

}  // namespace
}  // namespace glintlab
