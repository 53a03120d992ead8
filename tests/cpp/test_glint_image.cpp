// The ground truth of glint images (core/src/glinty/glint_image.cpp, docs/math/glint_images.md#glint-truth):
// stratified facets counted in footprint ellipses.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/glinty/glint_image.hpp"

using namespace glintlab;

namespace {
struct Pixels {
  std::vector<double> uv, jac, slope;
  std::size_t size() const { return uv.size() / 2; }
};

// m pixels on a line, each an ellipse of semi-axes (a, b) rotated by t (J = R diag(a, b) sqrt(pi)).
Pixels ellipses(std::size_t m, double a, double b, double t) {
  Pixels px;
  const double s = std::sqrt(std::numbers::pi);
  for (std::size_t i = 0; i < m; ++i) {
    px.uv.insert(px.uv.end(), {0.37 * static_cast<double>(i) + 0.011, 0.23 * static_cast<double>(i) - 5.0});
    px.jac.insert(px.jac.end(), {a * std::cos(t) * s, a * std::sin(t) * s, -b * std::sin(t) * s, b * std::cos(t) * s});
    px.slope.insert(px.slope.end(), {0.5 * static_cast<double>(i % 7), -0.25 * static_cast<double>(i % 5)});
  }
  return px;
}

std::vector<double> counts(const Pixels& px, double N, double p, std::uint64_t seed,
                           std::vector<std::uint8_t>* st = nullptr) {
  std::vector<double> k(px.size()), tested(px.size());
  std::vector<std::uint8_t> status(px.size());
  images::facet_counts(N, &p, 1, px.uv.data(), px.jac.data(), px.slope.data(), px.size(), seed, 1e8, k.data(),
                       status.data(), tested.data());
  if (st) *st = status;
  return k;
}
}  // namespace

TEST_CASE("facet counts: mean N P at p = 1, none at p = 0, monotone in p", "[images]") {
  const Pixels px = ellipses(2000, 0.2, 0.07, 0.6);
  const double N = 900.0, P = std::numbers::pi * 0.2 * 0.07;
  const auto k1 = counts(px, N, 1.0, 3), k0 = counts(px, N, 0.0, 3), kh = counts(px, N, 0.5, 3);
  double mean = 0, var = 0;
  for (std::size_t i = 0; i < k1.size(); ++i) {
    mean += k1[i];
    var += (k1[i] - N * P) * (k1[i] - N * P);
    CHECK(k0[i] == 0.0);
    CHECK(kh[i] <= k1[i]);
  }
  mean /= static_cast<double>(k1.size());
  var /= static_cast<double>(k1.size());
  CHECK(std::abs(mean - N * P) < 4 * std::sqrt(var / static_cast<double>(k1.size())));
  CHECK(var < 0.5 * N * P);  // stratified: far below Poisson's variance N P
}

TEST_CASE("facet counts do not depend on the number of threads, and bad input is refused by name", "[images]") {
  const Pixels px = ellipses(3000, 0.05, 0.01, 2.0);
  const int before = num_threads();
  set_num_threads(1);
  const auto a = counts(px, 1e4, 0.4, 11);
  set_num_threads(2);
  const auto b = counts(px, 1e4, 0.4, 11);
  set_num_threads(before);
  CHECK(a == b);
  CHECK(counts(px, 1e4, 0.4, 12) != a);
  Pixels bad = ellipses(2, 0.05, 0.01, 0.0);
  bad.jac[4] = bad.jac[7] = 0.0;  // the second footprint is a segment
  std::vector<std::uint8_t> status;
  const auto k = counts(bad, 1e4, 1.0, 1, &status);
  CHECK(status[0] == 0);
  CHECK(status[1] == static_cast<std::uint8_t>(images::FacetStatus::kDegenerate));
  CHECK(k[1] == 0.0);
  CHECK_THROWS_WITH(counts(px, -1.0, 0.5, 1), Catch::Contains("density = -1"));
  CHECK_THROWS_WITH(counts(px, 1e4, 1.5, 1), Catch::Contains("p[0] = 1.5"));
}
