// The mollified roulette's fast paths (core/blends/roulette.cpp): its closed-form moments against
// Gauss-Kronrod quadrature.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "glintlab/blend.hpp"
#include "glintlab/detail/roulette.hpp"

using namespace glintlab;

namespace {

using Moments = std::function<std::array<double, 2>(double, double)>;

// The weights of the comparison at one eps: a grid of step 1/2000 plus the breakpoints of R's pieces
// (0, eps, 2 eps, 1 - 2 eps, 1 - eps, 1) and their neighbouring doubles.
std::vector<double> test_weights(double eps) {
  std::vector<double> w;
  for (int i = 0; i <= 2000; ++i) w.push_back(i / 2000.0);
  for (double c : {0.0, eps, 2 * eps, 3 * eps, 0.5 * eps, 0.5, 1 - 3 * eps, 1 - 2 * eps, 1 - eps, 1.0, 1e-300, 1e-12}) {
    for (double x : {c, std::nextafter(c, -1.0), std::nextafter(c, 2.0)})
      if (x >= 0 && x <= 1) w.push_back(x);
  }
  return w;
}

std::vector<double> test_epsilons() {
  std::vector<double> e = {1e-9, 1e-6, 1e-3, 0.01, 0.1, 0.25, 0.49, std::nextafter(0.5, 0.0), 0.5};
  for (int i = 1; i <= 40; ++i) e.push_back(i / 80.0);
  return e;
}

// The largest absolute difference of either moment from the quadrature over the test grid.
double largest_difference(const Moments& moments) {
  double worst = 0;
  for (double eps : test_epsilons())
    for (double w : test_weights(eps)) {
      const auto a = moments(w, eps), q = blend_detail::roulette_moments_quadrature(w, eps);
      worst = std::max({worst, std::abs(a[0] - q[0]), std::abs(a[1] - q[1])});
    }
  return worst;
}

}  // namespace

TEST_CASE("the roulette's closed-form moments agree with quadrature", "[blend][roulette]") {
  // Largest difference measured: 9.9e-16 (eps and weight over the grid above). A tolerance of 4e-15:
  // about 20 ulps of 1, far below any missing or wrong piece (each is at least ~1e-4 somewhere).
  constexpr double kTolerance = 4e-15;
  const double worst = largest_difference(blend_detail::roulette_moments);
  INFO("largest |closed form - quadrature| = " << worst);
  CHECK(worst <= kTolerance);
  // The ends exactly: R is 0 (1) for every r at weight 0 (1), so the sums' variance is exactly 0.
  for (double eps : test_epsilons()) {
    CHECK(blend_detail::roulette_moments(0.0, eps) == std::array<double, 2>{0.0, 0.0});
    CHECK(blend_detail::roulette_moments(1.0, eps) == std::array<double, 2>{1.0, 1.0});
  }
  // The two levels' means add up to 1 at every weight (E[R(r, w)] + E[R(r, 1 - w)] = 1).
  for (double eps : test_epsilons())
    for (double w : test_weights(eps))
      CHECK(blend_detail::roulette_moments(w, eps)[0] + blend_detail::roulette_moments(1 - w, eps)[0] ==
            Approx(1.0).margin(1e-15));
  // The comparison catches a closed form with a piece missing (each of the three in turn).
  for (int dropped = 0; dropped < 3; ++dropped) {
    const double wrong = largest_difference([dropped](double w, double eps) {
      if (!(w > 0)) return std::array<double, 2>{0.0, 0.0};
      if (!(w < 1)) return std::array<double, 2>{1.0, 1.0};
      const auto p = blend_detail::roulette_moment_pieces(w, blend_detail::RouletteEps(eps));
      std::array<double, 2> m = {0.0, 0.0};
      for (int i = 0; i < 3; ++i)
        if (i != dropped)
          for (int j = 0; j < 2; ++j) m[j] += p[i][j];
      return m;
    });
    INFO("piece " << dropped << " dropped: largest difference " << wrong);
    CHECK(wrong > 1e3 * kTolerance);
  }
}
