// WWH18 in the core: TEA's known answer, the cone mass against closed forms, the model equal to the truth
// where it must be (whole cells, every flake counted), determinism across threads, bad parameters. The
// statistics (count laws, readings side by side) are in tests/python/test_wwh18.py.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/glinty/wwh18.hpp"

using namespace glintlab;

TEST_CASE("TEA known answer", "[wwh18]") {
  // The reference vector of the cipher: zero key, zero block, 32 cycles.
  std::uint32_t v0 = 0, v1 = 0;
  const std::uint32_t key[4] = {0, 0, 0, 0};
  tea_encrypt(v0, v1, key, 32);
  CHECK(v0 == 0x41ea3a0au);
  CHECK(v1 == 0x94baa940u);
}

TEST_CASE("cone mass against closed forms", "[wwh18]") {
  for (auto target : {GlintTarget::beckmann, GlintTarget::ggx}) {
    Wwh18Params p;
    p.target = target;
    p.alpha = 0.3;
    p.dpf = WwhDpf::exact;
    // A cone around the normal: the closed-form CDF of theta_m.
    for (double g : {2.0, 10.0, 40.0}) {
      p.gamma_deg = g;
      const Wwh18Ndf w(p);
      const double n[3] = {0, 0, 1};
      CHECK(w.cone_mass(n) == Approx(wwh18_theta_cdf(target, 0.3, g * std::numbers::pi / 180)).margin(1e-9));
    }
    // A narrow cone: p_gamma(h) ~ D(h)(h.n) times the cone's solid angle.
    p.gamma_deg = 0.05;
    const Wwh18Ndf w(p);
    const double h[3] = {std::sin(0.3), 0, std::cos(0.3)};
    const double c = std::cos(0.3), a2 = 0.09;
    const double D = target == GlintTarget::beckmann
                         ? std::exp(-(1 - c * c) / (c * c) / a2) / (std::numbers::pi * a2 * c * c * c * c)
                         : a2 / (std::numbers::pi * std::pow(c * c * (a2 - 1) + 1, 2));
    const double sigma = 2 * std::numbers::pi * (1 - std::cos(0.05 * std::numbers::pi / 180));
    CHECK(w.cone_mass(h) == Approx(D * c * sigma).epsilon(1e-5));
  }
}

TEST_CASE("the traversal equals the truth when every flake counts over whole cells", "[wwh18]") {
  // gamma = 90 degrees around the normal holds every flake (p = 1); H(P - lambda) then counts them all,
  // and a footprint made of whole base cells leaves no fractional node: model == truth, pixel by pixel.
  Wwh18Params p;
  p.density = 1e4;
  p.gamma_deg = 90;
  p.dpf = WwhDpf::exact;
  p.threshold_test = WwhThresholdTest::flipped;
  p.T = std::numeric_limits<double>::infinity();
  for (auto seeding : {WwhLambdaSeeding::node, WwhLambdaSeeding::flake}) {
    p.lambda_seeding = seeding;
    const Wwh18Ndf w(p);
    const double s = w.cell_side();
    const std::vector<double> uv = {10 * s, 20 * s, 3 * s + 0.5 * s, 7 * s + 0.5 * s};
    const std::vector<double> jac = {8 * s, 0, 0, 4 * s, 3 * s, 0, 0, 5 * s};
    const std::vector<double> h = {0, 0, 1, 0, 0, 1};
    std::vector<double> ref(2), model(2);
    std::vector<int> mode(2);
    w.reference_counts(uv.data(), jac.data(), h.data(), 2, 7, ref.data());
    w.counts(uv.data(), jac.data(), h.data(), nullptr, 2, 7, model.data(), mode.data());
    CHECK(ref[0] > 0);
    CHECK(model[0] == ref[0]);
    CHECK(model[1] == ref[1]);
    CHECK(mode[0] == kWwhTraversal);
  }
}

TEST_CASE("WWH18 is deterministic across thread counts", "[wwh18]") {
  Wwh18Params p;
  p.density = 1e5;
  p.lambda_seeding = WwhLambdaSeeding::flake;
  p.table_res_deg = 3;
  const Wwh18Ndf w(p);
  const std::size_t m = 200;
  std::vector<double> uv(2 * m), jac(4 * m), h(3 * m);
  for (std::size_t i = 0; i < m; ++i) {
    const auto x = static_cast<double>(i);
    uv[2 * i] = 0.013 * x;
    uv[2 * i + 1] = 0.007 * x;
    jac[4 * i] = 0.01 + 1e-4 * x;
    jac[4 * i + 1] = 0.002;
    jac[4 * i + 2] = -0.001;
    jac[4 * i + 3] = 0.012;
    h[3 * i] = 0.3;
    h[3 * i + 1] = -0.1;
    h[3 * i + 2] = 1.0;
  }
  const int saved = num_threads();
  std::vector<double> a(m), b(m), ra(m), rb(m);
  set_num_threads(1);
  w.counts(uv.data(), jac.data(), h.data(), nullptr, m, 3, a.data());
  w.reference_counts(uv.data(), jac.data(), h.data(), m, 3, ra.data());
  set_num_threads(2);
  w.counts(uv.data(), jac.data(), h.data(), nullptr, m, 3, b.data());
  w.reference_counts(uv.data(), jac.data(), h.data(), m, 3, rb.data());
  set_num_threads(saved);
  CHECK(a == b);
  CHECK(ra == rb);
}

TEST_CASE("WWH18 rejects bad parameters and footprints", "[wwh18]") {
  Wwh18Params p;
  p.dpf = WwhDpf::exact;
  auto bad = [](Wwh18Params q) { CHECK_THROWS_AS(Wwh18Ndf(q), std::invalid_argument); };
  Wwh18Params q = p;
  q.gamma_deg = 0;
  bad(q);
  q = p;
  q.table_res_deg = 7;
  bad(q);
  q = p;
  q.lod_deg = 3;
  bad(q);
  q = p;
  q.T = std::nan("");
  bad(q);
  const Wwh18Ndf w(p);
  const double uv[2] = {0, 0}, jac[4] = {1, 2, 2, 4}, h[3] = {0, 0, 1};
  double out = 0;
  CHECK_THROWS_AS(w.reference_counts(uv, jac, h, 1, 0, &out), std::invalid_argument);  // det J = 0
}

TEST_CASE("WWH18's cone solid angle and cell indices beyond 32 bits", "[wwh18]") {
  Wwh18Params p;
  p.dpf = WwhDpf::exact;
  for (double g : {1e-9, 1e-3, 6.0, 90.0}) {
    p.gamma_deg = g;
    const Wwh18Ndf w(p);
    const double half = std::sin(0.5 * g * std::numbers::pi / 180);
    CHECK(w.cone_solid_angle() > 0.0);
    CHECK(w.cone_solid_angle() == Approx(4 * std::numbers::pi * half * half).epsilon(1e-15));
  }
  p.gamma_deg = 6.0;
  for (WwhRng rng : {WwhRng::philox, WwhRng::tea}) {
    p.rng = rng;
    const Wwh18Ndf w(p);
    const std::int64_t big = std::int64_t{1} << 32, wrap = std::int64_t{1} << 16;
    for (std::int64_t i : {-7, 0, 12345}) {
      CHECK(w.lambda(3, 0, i, 5, 0) != w.lambda(3, 0, i + big, 5, 0));
      CHECK(w.lambda(3, 0, 5, i, 0) != w.lambda(3, 0, 5, i - big, 0));
      CHECK(w.lambda(3, 1, i, 5, 0) != w.lambda(3, 1, i + wrap, 4, 0));  // TEA's id i + 2^16 j repeats there
    }
  }
  // A footprint beyond 2^38 base cells of the origin is refused.
  const Wwh18Ndf w(p);
  const double uv[2] = {0.0, 1.01 * kWwhMaxCellIndex * w.cell_side()}, jac[4] = {1e-3, 0, 0, 1e-3}, h[3] = {0, 0, 1};
  double out = 0.0;
  CHECK_THROWS_AS(w.reference_counts(uv, jac, h, 1, 1, &out), std::invalid_argument);
}
