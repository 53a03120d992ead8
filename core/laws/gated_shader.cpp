// Law "gated_shader": DB23's gated Gaussian as the public HLSL implementation runs it
// (docs/math/laws.md#law-gated-shader), always in float32, including its departures from the paper:
//   - P1 = 1 - pow(|1 - p|, n) directly (not through expm1/log1p);
//   - n is continuous, with n >= 1 in the Gaussian's parameters: m = max(n, 1) - 1,
//     mu = m p, sd = sqrt(m p (1 - p));
//   - a soft gate: a linear ramp of half-width w = 0.1 clamp(10 P1, 0, 1) clamp(10 (1 - P1), 0, 1)
//     around P1, gate = saturate((P1 + w - theta0) / (2 w)) (the hard test theta0 < P1 if w <= 1e-7);
//   - G = clamp(floor(z sd + mu), 0, n) and K = gate (1 + G): K is not an integer on the ramp, and
//     can reach n + 1 (a measured defect, not a bug of this emulation);
//   - both randoms are read from 16-bit floats: theta0 = half(u0), and the Gaussian one is stored
//     already transformed, z = half(sqrt(2) erfinv(clamp(2 u1 - 1, -(1 - 1e-6), 1 - 1e-6))) with
//     Giles' (2010) single-precision erfinv polynomial.
// Binning: the law's output is reported (pmf) and compared (law.bin) as round-half-up(K), unit bins
// [k - 1/2, k + 1/2).
//
// Exact law: theta0 and z take finitely many half-float values, each with the probability of the set
// of u that rounds to it (tables computed once, u exact in double); K is a function of the pair, so
// the pmf of round(K) is an exact finite sum (gate values x Gaussian counts), up to the rounding of
// the boundaries of z's cells (found by bisection on u in double: error < 1e-15 per cell).
#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/base/float16.hpp"
#include "glintlab/detail/law_kernel.hpp"

namespace glintlab {
namespace {

// A shader's half(x): round to nearest even half, back to float (glintlab/base/float16.hpp: integer bit
// manipulation, identical to a _Float16 conversion, and portable to compilers without _Float16).
inline float to_half(float x) { return round_to_half(x); }

// Giles, "Approximating the erfinv function" (GPU Computing Gems, 2010), single-precision version.
float erfinv_giles(float x) {
  float w = -std::log((1.0f - x) * (1.0f + x)), p;
  if (w < 5.0f) {
    w -= 2.5f;
    p = 2.81022636e-08f;
    p = 3.43273939e-07f + p * w;
    p = -3.5233877e-06f + p * w;
    p = -4.39150654e-06f + p * w;
    p = 0.00021858087f + p * w;
    p = -0.00125372503f + p * w;
    p = -0.00417768164f + p * w;
    p = 0.246640727f + p * w;
    p = 1.50140941f + p * w;
  } else {
    w = std::sqrt(w) - 3.0f;
    p = -0.000200214257f;
    p = 0.000100950558f + p * w;
    p = 0.00134934322f + p * w;
    p = -0.00367342844f + p * w;
    p = 0.00573950773f + p * w;
    p = -0.0076224613f + p * w;
    p = 0.00943887047f + p * w;
    p = 1.00167406f + p * w;
    p = 2.83297682f + p * w;
  }
  return p * x;
}

// The stored Gaussian random for a uniform u (computed in float, stored as half).
float stored_gaussian(double u) {
  const float x = std::clamp(2.0f * static_cast<float>(u) - 1.0f, -(1.0f - 1e-6f), 1.0f - 1e-6f);
  return to_half(1.41421356f * erfinv_giles(x));
}

struct Parameters {
  float n, p1, mu, sd, w;
  Parameters(float nf, float pf) : n(nf) {
    p1 = 1.0f - std::pow(std::abs(1.0f - pf), nf);
    const float m = std::max(nf, 1.0f) - 1.0f;
    mu = m * pf;
    sd = std::sqrt(m * pf * (1.0f - pf));
    w = 0.1f * std::clamp(10.0f * p1, 0.0f, 1.0f) * std::clamp(10.0f * (1.0f - p1), 0.0f, 1.0f);
  }
  float gate(float theta0) const {
    if (w > 1e-7f) return std::clamp((p1 + w - theta0) / (2.0f * w), 0.0f, 1.0f);
    return theta0 < p1 ? 1.0f : 0.0f;
  }
  float gauss(float z) const { return std::clamp(std::floor(z * sd + mu), 0.0f, n); }
};

// Half-float values reachable by theta0 = half(u), u uniform on (0, 1), with their probabilities:
// the value v collects the u between the midpoints to its neighbours (ties to even are measure 0).
struct Cells {
  std::vector<float> value;
  std::vector<double> prob;
};

const Cells& uniform_cells() {
  static const Cells cells = [] {
    Cells c;
    std::vector<float> v;
    for (unsigned bits = 0; bits <= 0x3C00u; ++bits) {  // +0 .. 1.0 in half precision
      v.push_back(half_bits_to_float(static_cast<std::uint16_t>(bits)));
    }
    for (std::size_t i = 0; i < v.size(); ++i) {
      const double lo = i == 0 ? 0.0 : 0.5 * (static_cast<double>(v[i - 1]) + v[i]);
      const double hi = i + 1 == v.size() ? 1.0 : 0.5 * (static_cast<double>(v[i]) + v[i + 1]);
      c.value.push_back(v[i]);
      c.prob.push_back(hi - lo);
    }
    return c;
  }();
  return cells;
}

// Values of the stored Gaussian and their probabilities: z = stored_gaussian(u) is non-decreasing in
// u, so each value's cell is an interval of u, found by bisection on u.
const Cells& gaussian_cells() {
  static const Cells cells = [] {
    Cells c;
    double u = 0.0;
    float current = stored_gaussian(0.0);
    while (u < 1.0) {
      // Largest u' in [u, 1] with stored_gaussian(u') == current.
      double lo = u, hi = 1.0;
      if (stored_gaussian(1.0) == current) {
        c.value.push_back(current);
        c.prob.push_back(1.0 - u);
        break;
      }
      for (int it = 0; it < 80 && hi - lo > 0; ++it) {
        const double mid = 0.5 * (lo + hi);
        if (mid == lo || mid == hi) break;
        if (stored_gaussian(mid) == current)
          lo = mid;
        else
          hi = mid;
      }
      c.value.push_back(current);
      c.prob.push_back(hi - u);
      u = hi;
      current = stored_gaussian(hi);
    }
    return c;
  }();
  return cells;
}

class GatedShaderLaw final : public detail::KernelLaw<GatedShaderLaw> {
 public:
  std::string name() const override { return "gated_shader"; }
  int n_uniforms() const override { return 2; }

  // The shader computes in float whatever precision is asked: both give the same values.
  template <class T>
  T eval(T n, T p, const T* u) const {
    const Parameters par(static_cast<float>(n), static_cast<float>(p));
    const float theta0 = to_half(static_cast<float>(u[0]));
    const float z = stored_gaussian(static_cast<double>(u[1]));
    return static_cast<T>(par.gate(theta0) * (1.0f + par.gauss(z)));
  }

  bool has_pmf() const override { return true; }
  Distribution pmf(double n, double p, std::size_t max_support) const override {
    const Parameters par(static_cast<float>(n), static_cast<float>(p));
    // Law of the Gaussian count j = gauss(z).
    std::map<float, double> counts;
    const Cells& gz = gaussian_cells();
    for (std::size_t i = 0; i < gz.value.size(); ++i) counts[par.gauss(gz.value[i])] += gz.prob[i];
    // Law of the gate value.
    std::map<float, double> gates;
    const Cells& gu = uniform_cells();
    for (std::size_t i = 0; i < gu.value.size(); ++i) gates[par.gate(gu.value[i])] += gu.prob[i];
    if (counts.size() * gates.size() > 50'000'000)
      throw_invalid("gated_shader.pmf", "n", n, "parameters whose exact enumeration stays below 5e7 pairs");
    // round-half-up(gate (1 + j)), computed in float as the shader forms K.
    std::map<double, double> binned;
    for (const auto& [g, pg] : gates) {
      if (pg == 0) continue;
      for (const auto& [j, pj] : counts) {
        const float k = g * (1.0f + j);
        binned[std::floor(static_cast<double>(k) + 0.5)] += pg * pj;
      }
    }
    if (binned.size() > max_support)
      throw_invalid("gated_shader.pmf", "max_support", static_cast<double>(max_support), "a larger value");
    std::vector<double> ks, ps;
    for (const auto& [k, q] : binned) {
      if (q <= 0) continue;
      ks.push_back(k);
      ps.push_back(q);
    }
    return Distribution(std::move(ks), std::move(ps), /*normalize=*/true);
  }
};

const bool registered = register_parameterless_law<GatedShaderLaw>(
    "gated_shader", "DB23 gated Gaussian as the public shader runs it: float32, soft gate, half-float randoms",
    {.output = LawOutput::kReal,  // the soft gate's ramp
     .support = SupportBound::kNPlusOne,
     .support_note = "K = gate (1 + clamp(floor(G), 0, n)) reaches n + 1, as the public shader does",
     .constant_time = true,
     .regime = "the public shader's path, p <= 1/2 (an emulation: its defects are measured, not fixed)",
     .cost = "constant: pow, sqrt, a log and Giles' erfinv polynomial",
     .study_variants = {LawParams{}},
     .bench_variants = {LawParams{}},
     .test_variants = {LawParams{}},
     .bounds = {{.regime = {{"p_range", {0, 0.5}}},
                 .metrics = {"tv", "mean_rel_err"},
                 .reason = "the public shader's path, p <= 1/2"}},
     .shader = "gated"});

}  // namespace
}  // namespace glintlab
