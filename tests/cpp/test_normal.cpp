// The normal helpers: AS 241 quantile against Boost's erfc_inv; interval probabilities.
#include <boost/math/special_functions/erf.hpp>
#include <catch2/catch.hpp>
#include <cmath>

#include "glintlab/stats/normal.hpp"

using namespace glintlab;

TEST_CASE("AS 241 quantile matches Boost to a few eps in double, a few float eps in float", "[normal]") {
  double worst = 0, worst_f = 0;
  for (int i = 1; i < 200000; ++i) {
    // u over (0, 1) plus both tails down to 1e-300 (a log-spaced sweep).
    const double t = i / 200000.0;
    for (double u : {t, std::pow(10.0, -300.0 * t), 1 - std::pow(10.0, -16.0 * t)}) {
      if (!(u > 0 && u < 1)) continue;
      const double want = -std::sqrt(2.0) * boost::math::erfc_inv(2 * u);
      const double got = normal::quantile(u);
      const double err = std::abs(got - want) / std::max(1.0, std::abs(want));
      if (err > worst) worst = err;
      const float uf = static_cast<float>(u);
      if (uf > 0 && uf < 1) {
        const double want_f = -std::sqrt(2.0) * boost::math::erfc_inv(2.0 * static_cast<double>(uf));
        const double err_f = std::abs(normal::quantile(uf) - want_f) / std::max(1.0, std::abs(want_f));
        if (err_f > worst_f) worst_f = err_f;
      }
    }
  }
  INFO("worst relative error: double " << worst << ", float " << worst_f);
  CHECK(worst < 1e-14);
  CHECK(worst_f < 2e-6);
  CHECK(std::isinf(normal::quantile(0.0)));
  CHECK(std::isinf(normal::quantile(1.0)));
  CHECK(normal::quantile(0.5) == 0.0);
}

TEST_CASE("normal interval probabilities keep both tails", "[normal]") {
  CHECK(normal::interval(-INFINITY, INFINITY) == Approx(1.0));
  CHECK(normal::interval(8, 9) == Approx(normal::sf(8) - normal::sf(9)).epsilon(1e-12));
  CHECK(normal::interval(8, 9) > 0);
  CHECK(normal::interval(-9, -8) == Approx(normal::interval(8, 9)).epsilon(1e-12));
  CHECK(normal::interval(1, 0) == 0.0);
}
