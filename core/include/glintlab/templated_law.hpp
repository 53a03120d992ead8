// Base for constant-time laws written once as a template over the arithmetic type, so that float64
// and float32 evaluation run the same code (issue: float32 fidelity of shader laws).
//
//   class MyLaw final : public TemplatedLaw<MyLaw> {
//    public:
//     template <class T> T eval(T n, T p, const T* u) const;   // K from (n, p, u), in T
//     ...
//   };
//
// float32 evaluation rounds n and p to float first, as a shader that receives them as floats would,
// and turns the uniforms into floats by the rule of float32.hpp (never 0 or 1), the rule the Vulkan
// shader runner applies too, so that a shader and its C++ twin compare row by row.
#pragma once

#include <array>

#include "glintlab/float32.hpp"
#include "glintlab/law.hpp"

namespace glintlab {

inline constexpr int kMaxTemplatedUniforms = 64;

template <class Derived>
class TemplatedLaw : public CountingLaw {
 public:
  double evaluate(double n, double p, const double* u) const override { return self().template eval<double>(n, p, u); }
  double evaluate_f32(double n, double p, const double* u) const override {
    std::array<float, kMaxTemplatedUniforms> uf{};
    for (int i = 0; i < n_uniforms(); ++i) uf[static_cast<std::size_t>(i)] = uniform_to_float(u[i]);
    return static_cast<double>(self().template eval<float>(static_cast<float>(n), static_cast<float>(p), uf.data()));
  }
  bool supports(Precision) const override { return true; }

 private:
  const Derived& self() const { return static_cast<const Derived&>(*this); }
};

}  // namespace glintlab
