// KPT25's glinty NDF in the core: the roulette, the disk integral, exactness of Algorithm 1 when B(k)
// covers every cell, determinism across threads, bad parameters (the Python tests cover the statistics
// and the independent brute-force sum).
#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"

using namespace glintlab;

TEST_CASE("the mollified roulette of eq. 8", "[glinty_ndf]") {
  CHECK(kpt25_roulette(0.3, 0.4, 0.0) == 1.0);  // eps = 0: keep when w >= r
  CHECK(kpt25_roulette(0.5, 0.4, 0.0) == 0.0);
  CHECK(kpt25_roulette(0.5, 0.5, 0.1) == Approx(0.5));
  CHECK(kpt25_roulette(0.2, 0.0, 0.1) == 0.0);
  CHECK(kpt25_roulette(0.95, 1.0, 0.1) == 1.0);
  // R(1 - r, 1 - w) = 1 - R(r, w): the two levels' expected keep rates add up to 1.
  for (double r : {0.01, 0.07, 0.3, 0.93})
    for (double w : {0.0, 0.05, 0.5, 0.97})
      CHECK(kpt25_roulette(1 - r, 1 - w, 0.1) == Approx(1 - kpt25_roulette(r, w, 0.1)).margin(1e-12));
}

TEST_CASE("Gaussian mass in the disk and a rectangle", "[glinty_ndf]") {
  // A narrow lobe at the centre lies inside; one centred on the rim is cut in half (to first order).
  CHECK(gaussian_in_disk_rect(0.5, 0.5, 0.01, 0, 1, 0, 1) == Approx(1.0).margin(1e-10));
  CHECK(gaussian_in_disk_rect(1.0, 0.5, 1e-4, 0, 1, 0, 1) == Approx(0.5).margin(1e-3));
  // Rectangle entirely inside the disk: product of 1D masses.
  const double m = std::erf(0.05 / (0.05 * std::sqrt(2.0)));
  CHECK(gaussian_in_disk_rect(0.5, 0.5, 0.05, 0.45, 0.55, 0.45, 0.55) == Approx(m * m).epsilon(1e-9));
  // Whole disk for a wide lobe: the disk's share of a nearly flat density = pi / 4 of the square's.
  const double wide = gaussian_in_disk_rect(0.5, 0.5, 50.0, 0, 1, 0, 1);
  CHECK(wide * 2 * M_PI * 2500.0 == Approx(M_PI / 4).epsilon(1e-4));  // flat to (1/2)^2 / (8 sigma^2)
}

namespace {
std::vector<double> tile(std::vector<double> v, std::size_t n) {
  std::vector<double> out;
  for (std::size_t i = 0; i < n; ++i) out.insert(out.end(), v.begin(), v.end());
  return out;
}
}  // namespace

TEST_CASE("Algorithm 1 equals the reference when B(k) covers every angular cell", "[glinty_ndf]") {
  Kpt25Params p;
  p.density = 100.0;
  p.alpha_star = 0.1;
  p.k = 16;
  const std::size_t n = 64;
  std::vector<double> uv(2 * n), jac = tile({0.05, 0.01, 0.0, 0.04}, n), h = tile({0.3, 0.1, 1.0}, n);
  for (std::size_t i = 0; i < n; ++i) {
    uv[2 * i] = 0.37 * static_cast<double>(i);
    uv[2 * i + 1] = 0.11 * static_cast<double>(i % 7);
  }
  std::vector<double> ref(n), alg(n), wrong(n);
  const Kpt25Ndf ndf(p);
  REQUIRE(ndf.pixel(jac.data(), h.data(), 0).levels[1] <= 2);
  ndf.reference(uv.data(), jac.data(), h.data(), n, 5, ref.data());
  ndf.evaluate(uv.data(), jac.data(), h.data(), n, 5, alg.data());
  p.compensation = GlintCompensation::square_flipped;
  Kpt25Ndf(p).evaluate(uv.data(), jac.data(), h.data(), n, 5, wrong.data());
  int nonzero = 0, differ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    CHECK(alg[i] == Approx(ref[i]).epsilon(1e-12).margin(0));
    nonzero += ref[i] > 0;
    differ += std::abs(wrong[i] - ref[i]) > 1e-3 * (1 + ref[i]);
  }
  CHECK(nonzero > 10);
  CHECK(differ == static_cast<int>(n));
}

TEST_CASE("glinty NDF images do not depend on the number of threads", "[glinty_ndf]") {
  Kpt25Params p;
  p.density = 1e5;
  p.target = GlintTarget::ggx;
  const std::size_t n = 2000;
  std::vector<double> uv(2 * n), jac(4 * n), h(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i);
    uv[2 * i] = std::fmod(t * 0.618, 1.0);
    uv[2 * i + 1] = std::fmod(t * 0.414, 1.0);
    jac[4 * i] = 2e-3 + 1e-6 * t;
    jac[4 * i + 3] = 3e-3;
    jac[4 * i + 1] = 5e-4;
    h[3 * i] = std::sin(t);
    h[3 * i + 1] = std::cos(t * 0.7) * 0.5;
    h[3 * i + 2] = 1.0;
  }
  const int threads = num_threads();
  std::vector<double> one(n), two(n);
  set_num_threads(1);
  Kpt25Ndf(p).evaluate(uv.data(), jac.data(), h.data(), n, 9, one.data());
  set_num_threads(2);
  Kpt25Ndf(p).evaluate(uv.data(), jac.data(), h.data(), n, 9, two.data());
  set_num_threads(threads);
  CHECK(one == two);
}

TEST_CASE("bad glinty NDF parameters are refused by name", "[glinty_ndf]") {
  auto refused = [](auto change, const std::string& name) {
    Kpt25Params p;
    change(p);
    try {
      Kpt25Ndf ndf(p);
      FAIL("accepted a bad " + name);
    } catch (const std::invalid_argument& e) { CHECK(std::string(e.what()).find(name + " = ") != std::string::npos); }
  };
  refused([](Kpt25Params& p) { p.density = 0; }, "density");
  refused([](Kpt25Params& p) { p.alpha = NAN; }, "alpha");
  refused([](Kpt25Params& p) { p.alpha_star = -1; }, "alpha_star");
  refused([](Kpt25Params& p) { p.k = 2; }, "k");
  refused([](Kpt25Params& p) { p.epsilon = 0.6; }, "epsilon");
  refused([](Kpt25Params& p) { p.filter = INFINITY; }, "filter");
  const Kpt25Ndf ndf{Kpt25Params{}};
  const double uv[2] = {0, 0}, jac[4] = {1e-3, 0, 0, 0}, h[3] = {0, 0, 1};
  double out = 0;
  CHECK_THROWS_AS(ndf.evaluate(uv, jac, h, 1, 0, &out), std::invalid_argument);
}

TEST_CASE("Algorithm 2: the area of a rectangle in the disk, T^-1, and sample against pdf", "[glinty_ndf]") {
  CHECK(rect_disk_area(0, 1, 0, 1) == Approx(M_PI / 4).epsilon(1e-14));
  CHECK(rect_disk_area(0.5, 1, 0, 0.5) == Approx(M_PI / 16).epsilon(1e-14));
  CHECK(rect_disk_area(0.45, 0.55, 0.45, 0.55) == Approx(0.01).epsilon(1e-14));  // inside
  CHECK(rect_disk_area(0.9, 1.0, 0.9, 1.0) == 0.0);                              // a corner outside
  for (GlintTarget t : {GlintTarget::beckmann, GlintTarget::ggx}) {
    Kpt25Params p;
    p.target = t;
    p.density = 1e4;
    p.alpha_star = 0.05;
    const Kpt25Ndf ndf(p);
    for (double x : {0.5, 0.2, 0.93})
      for (double y : {0.5, 0.61}) {
        const auto h = ndf.inverse_map(x, y);
        const auto back = ndf.map(h.data());
        CHECK(back[0] == Approx(x).margin(1e-13));
        CHECK(back[1] == Approx(y).margin(1e-13));
      }
    const std::size_t n = 300;
    const auto uv = tile({0.3, 0.4}, n), jac = tile({0.02, 0.0, 0.0, 0.02}, n);
    std::vector<double> h(3 * n), pdf(n), again(n);
    ndf.sample(uv.data(), jac.data(), nullptr, n, 7, 1, h.data(), pdf.data(), nullptr);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (std::isfinite(h[3 * i])) {
        for (int c = 0; c < 3; ++c) h[3 * kept + c] = h[3 * i + c];
        pdf[kept++] = pdf[i];
      }
    CHECK(kept > n / 2);
    ndf.pdf(uv.data(), jac.data(), h.data(), kept, 7, again.data());
    for (std::size_t i = 0; i < kept; ++i) CHECK(again[i] == pdf[i]);
  }
  Kpt25Params bad;
  bad.sample_smooth = 1.5;
  CHECK_THROWS_AS(Kpt25Ndf(bad), std::invalid_argument);
}
