// Ground truth (spatialized Bernoulli trials): geometry, exact laws, realizations, joint counts.
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/counting/spatial.hpp"
#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/chi2.hpp"

using namespace glintlab;
using namespace glintlab::spatial;

namespace {
std::vector<Footprint> shapes() {
  return {Footprint::rect(0.1, 0.07, 0.3), Footprint::rect(0.1, 0.05, 0.0), Footprint::ellipse(0.06, 0.03, 1.0),
          Footprint::ellipse(0.04, 0.04, 0.0), Footprint::rect(0.02, 0.15, 2.0)};
}
}  // namespace

TEST_CASE("overlaps are exact: covered cells add up to the area, boxes match quadrature", "[spatial]") {
  for (const auto& f : shapes()) {
    for (auto [x, y] : {std::pair{0.5, 0.5}, {0.503, 0.507}, {0.0101, 0.9973}}) {
      const auto cov = stratified_coverage(f, x, y, 100);
      double sum = cov.interior;
      for (double q : cov.fractions) sum += q;
      INFO(f.describe() << " at " << x << ", " << y);
      CHECK(sum == Approx(f.area() * 1e4).epsilon(1e-11));
    }
    // One box across the edge against a 1500 x 1500 midpoint quadrature of contains().
    const double x0 = -0.02, y0 = 0.0, x1 = 0.04, y1 = 0.05;
    const int q = 1500;
    double inside = 0;
    for (int i = 0; i < q; ++i)
      for (int j = 0; j < q; ++j) inside += f.contains(x0 + (x1 - x0) * (i + 0.5) / q, y0 + (y1 - y0) * (j + 0.5) / q);
    const double quad = inside / (double(q) * q) * (x1 - x0) * (y1 - y0);
    INFO(f.describe());
    CHECK(f.overlap(x0, y0, x1, y1) == Approx(quad).epsilon(2e-3));
  }
}

TEST_CASE("the footprint of UV derivatives has the pixel's area and maps the disk", "[spatial]") {
  const double dudx = 0.01, dvdx = 0.002, dudy = -0.001, dvdy = 0.005;
  const auto f = Footprint::from_uv_derivatives(dudx, dvdx, dudy, dvdy);
  CHECK(f.area() == Approx(std::abs(dudx * dvdy - dudy * dvdx)).epsilon(1e-12));
  const double r = 1 / std::sqrt(std::numbers::pi);
  for (int i = 0; i < 64; ++i) {
    const double t = 2 * std::numbers::pi * i / 64, cx = std::cos(t), cy = std::sin(t);
    // J (0.999 r e) is inside, J (1.001 r e) outside.
    CHECK(f.contains(0.999 * r * (dudx * cx + dudy * cy), 0.999 * r * (dvdx * cx + dvdy * cy)));
    CHECK_FALSE(f.contains(1.001 * r * (dudx * cx + dudy * cy), 1.001 * r * (dvdx * cx + dvdy * cy)));
  }
  CHECK_THROWS_AS(Footprint::from_uv_derivatives(1, 2, 2, 4), std::invalid_argument);
}

TEST_CASE("realizations follow the exact law of every layout and footprint", "[spatial][statistical]") {
  // 5 footprints x 3 layouts x (fixed, random centre) = 30 chi-square tests at a Sidak-corrected
  // family false-failure rate of 1e-3 (fixed seeds: the outcome is deterministic).
  const double alpha = sidak_alpha(1e-3, 30);
  for (const auto& f : shapes())
    for (Layout layout : {Layout::kStratified, Layout::kPoisson, Layout::kUniform})
      for (bool fixed : {true, false}) {
        std::optional<std::pair<double, double>> c;
        if (fixed) c = std::pair{0.503, 0.507};
        const GroundTruth gt(layout, 1e4, f, 0.3, c);
        const auto x = gt.sample(100'000, 11);
        const auto res = chi2_test(x.data(), x.size(), gt.pmf());
        INFO(layout_name(layout) << " " << f.describe() << (fixed ? " fixed centre" : " random centre")
                                 << ": p = " << res.pvalue);
        CHECK(res.pvalue > alpha);
      }
}

TEST_CASE("the chi-square check rejects a footprint 1% too large", "[spatial][statistical][power]") {
  // Negative control: the same realizations against the law of a slightly larger footprint.
  for (Layout layout : {Layout::kStratified, Layout::kPoisson, Layout::kUniform}) {
    const GroundTruth gt(layout, 1e4, Footprint::rect(0.1, 0.07, 0.3), 0.3);
    const GroundTruth wrong(layout, 1e4, Footprint::rect(0.1, 0.0707, 0.3), 0.3);
    const auto x = gt.sample(100'000, 11);
    INFO(layout_name(layout));
    CHECK(chi2_test(x.data(), x.size(), wrong.pmf()).pvalue < 1e-6);
  }
  // And the stratified law is not the binomial of n = N |F| trials when the edge cuts cells.
  const GroundTruth gt(Layout::kStratified, 1e4, Footprint::rect(0.1, 0.07, 0.3), 0.5, std::pair{0.503, 0.507});
  const auto x = gt.sample(400'000, 3);
  CHECK(chi2_test(x.data(), x.size(), make_law("binomial")->pmf(gt.n(), 0.5, kDefaultMaxSupport)).pvalue < 1e-6);
}

TEST_CASE("the stratified law is the binomial when the footprint is a union of cells", "[spatial]") {
  // A 10 x 7 block of cells of a 100 x 100 grid: K ~ Binomial(70, p) exactly.
  const GroundTruth gt(Layout::kStratified, 1e4, Footprint::rect(0.1, 0.07), 0.3, std::pair{0.55, 0.535});
  const auto d = gt.pmf();
  // (The edges sit on cell boundaries up to rounding, so slivers of 1e-15 may appear: compare
  // probabilities point by point, not supports.)
  double worst = 0;
  for (std::size_t i = 0; i < d.size(); ++i)
    worst = std::max(worst, std::abs(d.probs()[i] - binomial::pmf(d.support()[i], 70, 0.3)));
  CHECK(worst < 1e-13);
  CHECK(d.mean() == Approx(21).epsilon(1e-12));
}

TEST_CASE("realizations do not depend on the number of threads", "[spatial]") {
  const GroundTruth gt(Layout::kPoisson, 1e6, Footprint::ellipse(0.02, 0.01, 0.5), 0.2);
  set_num_threads(1);
  const auto one = gt.sample(5000, 9);
  set_num_threads(2);
  const auto two = gt.sample(5000, 9);
  CHECK(one == two);
  CHECK(gt.sample(5000, 10) != two);
}

TEST_CASE("joint counts: nested footprints are ordered and each column has its exact law", "[spatial][statistical]") {
  const std::vector<Placed> path{{Footprint::rect(0.03, 0.03), 0.5, 0.5},
                                 {Footprint::rect(0.05, 0.05, 0.2), 0.5, 0.5},
                                 {Footprint::ellipse(0.05, 0.04), 0.51, 0.49}};
  const std::size_t count = 50'000;
  for (Layout layout : {Layout::kStratified, Layout::kPoisson, Layout::kUniform}) {
    const auto k = joint_counts(layout, 1e4, 0.4, path, count, 5);
    for (std::size_t r = 0; r < count; ++r) REQUIRE(k[3 * r] <= k[3 * r + 1]);  // the 0.03 square lies in the other
    for (std::size_t j = 0; j < path.size(); ++j) {
      std::vector<double> col(count);
      for (std::size_t r = 0; r < count; ++r) col[r] = k[3 * r + j];
      const GroundTruth gt(layout, 1e4, path[j].footprint, 0.4, std::pair{path[j].x, path[j].y});
      INFO(layout_name(layout) << " column " << j);
      CHECK(chi2_test(col.data(), count, gt.pmf()).pvalue > sidak_alpha(1e-3, 9));
    }
  }
  // A footprint across the torus seam is gathered next to the others (same counts as unwrapped).
  const auto a = joint_counts(Layout::kStratified, 1e4, 0.4, {{Footprint::rect(0.05, 0.05), 0.99, 0.5}}, 1000, 1);
  const auto b = joint_counts(Layout::kStratified, 1e4, 0.4, {{Footprint::rect(0.05, 0.05), -0.01, 0.5}}, 1000, 1);
  CHECK(a == b);
}

TEST_CASE("bad ground-truth input is refused by name", "[spatial]") {
  const auto f = Footprint::rect(0.1, 0.1);
  CHECK_THROWS_WITH(GroundTruth(Layout::kStratified, 10, f, 0.3), Catch::Contains("density = 10"));
  CHECK_THROWS_WITH(GroundTruth(Layout::kUniform, 10.5, f, 0.3), Catch::Contains("density = 10.5"));
  CHECK_THROWS_WITH(GroundTruth(Layout::kPoisson, -1, f, 0.3), Catch::Contains("density = -1"));
  CHECK_THROWS_WITH(GroundTruth(Layout::kPoisson, NAN, f, 0.3), Catch::Contains("density = nan"));
  CHECK_THROWS_WITH(GroundTruth(Layout::kPoisson, 100, f, 1.5), Catch::Contains("p = 1.5"));
  CHECK_THROWS_WITH(GroundTruth(Layout::kPoisson, 100, Footprint::rect(1.2, 0.1), 0.5),
                    Catch::Contains("bounding box"));
  CHECK_THROWS_WITH(GroundTruth(Layout::kPoisson, 100, f, 0.5, std::pair{INFINITY, 0.0}), Catch::Contains("center[0]"));
  CHECK_THROWS_WITH(Footprint::rect(-1, 1), Catch::Contains("width = -1"));
  CHECK_THROWS_WITH(Footprint::ellipse(1, 0), Catch::Contains("b = 0"));
  CHECK_THROWS_WITH(Footprint::ellipse(1, NAN), Catch::Contains("b = nan"));
  CHECK_THROWS_WITH(parse_layout("grid"), Catch::Contains("layout"));
  const auto big = Footprint::rect(0.4, 0.4);  // three of them spread over 1.07 of the domain
  CHECK_THROWS_WITH(
      joint_counts(Layout::kPoisson, 100, 0.5, {{big, 0.0, 0.5}, {big, 0.33, 0.5}, {big, 0.66, 0.5}}, 10, 1),
      Catch::Contains("fit in the unit domain"));
}
