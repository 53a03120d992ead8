// The direction-sampler harness's core: Genz-Malik cubature on polynomials it must integrate exactly,
// the area-preserving maps, the adaptive bins on a known density, and the chi-square with the lost bin.
#include <catch2/catch.hpp>
#include <cmath>
#include <numbers>
#include <vector>

#include "glintlab/sampling/sampler_test.hpp"

using namespace glintlab::sampling;

namespace {
// Drives the pull interface with a C++ density (the Python driver does the same with a callable).
template <class F>
void fill(Bins& b, Domain d, F pdf) {
  const int dim = domain_dim(d);
  while (!b.done()) {
    const auto& nodes = b.nodes();
    std::vector<double> v(nodes.size() / dim);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = pdf(&nodes[i * dim]);
    b.supply(v.data(), v.size());
  }
}
}  // namespace

TEST_CASE("Genz-Malik is exact to degree 7 and its error estimate sees degree 6", "[sampler_test]") {
  const Rect r{0.25, 0.5, 0.5, 0.25};
  double st[2 * kGenzMalikNodes], f[kGenzMalikNodes];
  genz_malik_nodes(r, st);
  // integral of s^a t^b over [0.25, 0.75] x [0.5, 0.75]
  auto exact = [](int a, int b) {
    return (std::pow(0.75, a + 1) - std::pow(0.25, a + 1)) / (a + 1) * (std::pow(0.75, b + 1) - std::pow(0.5, b + 1)) /
           (b + 1);
  };
  for (int a = 0; a <= 7; ++a)
    for (int b = 0; a + b <= 7; ++b) {
      for (int k = 0; k < kGenzMalikNodes; ++k) f[k] = std::pow(st[2 * k], a) * std::pow(st[2 * k + 1], b) + 1.0;
      double value = 0.0, error = 0.0;
      genz_malik_integrate(r, f, value, error);
      CHECK(value == Approx(exact(a, b) + 0.125).epsilon(1e-12));
      if (a + b <= 5) CHECK(error == Approx(0.0).margin(1e-14));
    }
  for (int k = 0; k < kGenzMalikNodes; ++k) f[k] = std::pow(st[2 * k] - 0.5, 6);
  double value = 0.0, error = 0.0;
  genz_malik_integrate(r, f, value, error);
  CHECK(error > 0.0);
}

TEST_CASE("the maps are area preserving and invert", "[sampler_test]") {
  for (Domain d : {Domain::hemisphere, Domain::sphere, Domain::disk, Domain::square}) {
    double p[3];
    from_square(d, 0.3, 0.7, p);
    double s = 0, t = 0;
    std::uint8_t lost = 1;
    to_square(d, p, 1, 1e-9, &s, &t, &lost);
    CHECK(lost == 0);
    CHECK(s == Approx(0.3));
    CHECK(t == Approx(0.7));
  }
  const double below[3] = {0.0, 0.6, -0.8}, long_[3] = {0.0, 0.0, 1.01}, nan[3] = {NAN, 0.0, 1.0};
  double s = 0, t = 0;
  std::uint8_t lost = 0;
  for (const double* p : {below, long_, nan}) {
    to_square(Domain::hemisphere, p, 1, 1e-4, &s, &t, &lost);
    CHECK(lost == 1);
  }
  CHECK(domain_measure(Domain::hemisphere) == Approx(2 * std::numbers::pi));
}

TEST_CASE("adaptive bins integrate a peaked density to 1 and split where its mass is", "[sampler_test]") {
  // A normalised Beckmann lobe D(h)(h.n) of alpha = 0.1 on the hemisphere.
  const double a2 = 0.01;
  auto pdf = [&](const double* h) {
    const double c = h[2];
    if (c <= 0) return 0.0;
    const double tan2 = (1 - c * c) / (c * c);
    return std::exp(-tan2 / a2) / (std::numbers::pi * a2 * c * c * c * c) * c;
  };
  BinOptions o;
  o.total = 1e6;
  o.target = 1000;
  Bins b(Domain::hemisphere, o, nullptr, nullptr, 0);
  fill(b, Domain::hemisphere, pdf);
  double sum = 0, err = 0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    sum += b.integral()[i];
    err += b.error()[i];
    CHECK(o.total * b.error()[i] <= o.rel_tol * std::sqrt(std::max(o.total * b.integral()[i], 1.0)) * (1 + 1e-12));
    CHECK(o.total * b.integral()[i] <= o.target);
  }
  CHECK(b.unconverged() == 0);
  CHECK(sum == Approx(1.0).epsilon(1e-7));
  CHECK(err * o.total < 0.1 * std::sqrt(o.total));  // far below the statistical resolution of the total
  // Bins are small near the pole (s = cos theta -> 1) and large elsewhere.
  int fine = 0;
  for (std::size_t i = 0; i < b.size(); ++i)
    if (b.rects()[i].s0 > 0.9 && b.depths()[i] >= 6) ++fine;
  CHECK(fine > 100);
  std::vector<double> s{0.999, 0.1, -1}, t{0.5, 0.5, -1};
  std::vector<std::int64_t> bin(3);
  b.locate(s.data(), t.data(), 3, bin.data());
  CHECK(bin[2] == -1);
  const Rect& r = b.rects()[static_cast<std::size_t>(bin[0])];
  CHECK((r.s0 <= 0.999 && 0.999 < r.s0 + r.ws && r.t0 <= 0.5 && 0.5 < r.t0 + r.wt));
}

TEST_CASE("chi_square: merged bins, the lost bin and the no-power case", "[sampler_test]") {
  // Four bins of mass 0.25 each, a perfect fit.
  std::vector<double> integral(4, 0.25), error(4, 0.0), obs{250, 250, 250, 250};
  auto r = chi_square(obs, integral, error, 0, 1000, 5);
  CHECK(r.statistic == 0.0);
  CHECK(r.dof == 3);
  CHECK(r.pvalue == Approx(1.0));
  // One sample lost where the pdf integrates to 1: an exact Poisson test at lambda ~ 0 rejects.
  std::vector<double> obs2{250, 250, 250, 249};
  r = chi_square(obs2, integral, error, 1, 1000, 5);
  CHECK(r.pvalue_lost == 0.0);
  CHECK(r.pvalue == 0.0);
  // A pdf that integrates to 0.9: 100 expected lost samples; 100 lost pass, 0 lost and 200 lost reject.
  std::vector<double> integral3(4, 0.225), obs3{225, 225, 225, 225};
  r = chi_square(obs3, integral3, error, 100, 1000, 5);
  CHECK(r.lost_expected == Approx(100));
  CHECK(r.pvalue_lost > 0.5);
  CHECK(chi_square(obs3, integral3, error, 0, 1000, 5).pvalue_lost < 1e-40);
  CHECK(chi_square(obs3, integral3, error, 200, 1000, 5).pvalue_lost < 1e-15);
  // A cubature error of 0.01 makes 110 lost samples unremarkable.
  std::vector<double> error3(4, 0.0025);
  CHECK(chi_square(obs3, integral3, error3, 110, 1000, 5).pvalue_lost == Approx(1.0));
  // Too few samples: everything merges into one bin, NaN and a note.
  std::vector<double> obs4{1, 0, 1, 0};
  r = chi_square(obs4, integral, error, 0, 2, 5);
  CHECK(std::isnan(r.pvalue));
  CHECK(r.note.find("no power") != std::string::npos);
}

TEST_CASE("the global cubature rule bounds the statistic's shift where the per-bin rule cannot converge",
          "[sampler_test]") {
  // Uniform density on a disk of radius 0.3 in the unit square: a jump along a circle, integrated by the
  // cubature only to first order in the cell size. Its exact mass per bin is not needed: the bound B and
  // the mass's error are what the rule controls.
  auto pdf = [](const double* p) {
    const double dx = p[0] - 0.5, dy = p[1] - 0.5;
    return dx * dx + dy * dy < 0.09 ? 1.0 / (std::numbers::pi * 0.09) : 0.0;
  };
  BinOptions o;
  o.total = 1e5;
  o.target = 400;
  o.max_nodes = 1'500'000;
  BinOptions per_bin = o;  // the old rule alone: 2 % of each bin's noise
  Bins old(Domain::square, per_bin, nullptr, nullptr, 0);
  fill(old, Domain::square, pdf);
  CHECK(old.unconverged() > 0);
  BinOptions global = o;
  global.rel_tol = 0.0;
  global.shift_tol = 0.1;
  Bins b(Domain::square, global, nullptr, nullptr, 0);
  fill(b, Domain::square, pdf);
  CHECK(b.unconverged() == 0);
  CHECK(b.shift_bound() > 0.0);
  CHECK(b.shift_bound() <= b.shift_limit());
  CHECK(b.evaluations() < old.evaluations());
  double sum = 0;
  for (std::size_t i = 0; i < b.size(); ++i) sum += b.integral()[i];
  CHECK(sum == Approx(1.0).epsilon(1e-3));
  // Bad tolerances name the parameter.
  BinOptions bad = o;
  bad.shift_tol = -1.0;
  CHECK_THROWS_WITH(Bins(Domain::square, bad, nullptr, nullptr, 0), Catch::Contains("cubature_tol"));
}

TEST_CASE("chi_square: a pdf integrating above 1 beyond its error fails as one below 1 does", "[sampler_test]") {
  // 1e5 samples, none lost. Mass 1.0013 +- 0.00024 claims 106 samples more than were drawn; 0.9975 +- 0.00024
  // leaves 226 unexplained by any loss: both reject. Within its error of 1 either way, nothing happens.
  std::vector<double> obs{25000, 25000, 25000, 25000}, error(4, 0.00006);
  auto with_mass = [&](double m) {
    return chi_square(obs, std::vector<double>(4, m / 4), error, 0, 1e5, 5).pvalue_lost;
  };
  CHECK(with_mass(1.0013) < 1e-40);
  CHECK(with_mass(0.9975) < 1e-40);
  CHECK(with_mass(1.0002) == Approx(1.0));
  CHECK(with_mass(0.9998) == Approx(1.0));
  // A mass just above 1 + error claims a sample or two: no rejection (exp(-1) = 0.37, two-sided 0.74).
  CHECK(with_mass(1.00025) > 0.5);
}

namespace {
// GGX's D(h)(h.n) per steradian at roughness alpha (normalised on the hemisphere).
auto ggx(double alpha) {
  return [alpha](const double* h) {
    const double c = h[2];
    if (c <= 0) return 0.0;
    const double a2 = alpha * alpha, d = c * c * (a2 - 1.0) + 1.0;
    return a2 / (std::numbers::pi * d * d) * c;
  };
}

// Pilot points drawn from GGX at roughness alpha (its square coordinates) and the pdf there.
void ggx_pilot(double alpha, std::size_t n, std::vector<double>& s, std::vector<double>& t, std::vector<double>& q) {
  const auto pdf = ggx(alpha);
  for (std::size_t i = 0; i < n; ++i) {
    const double u = (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double v = std::fmod(0.618033988749895 * static_cast<double>(i), 1.0);
    const double tan2 = alpha * alpha * u / (1.0 - u), z = 1.0 / std::sqrt(1.0 + tan2);
    s.push_back(z);
    t.push_back(v);
    double h[3];
    from_square(Domain::hemisphere, z, v, h);
    q.push_back(pdf(h));
  }
}
}  // namespace

TEST_CASE("a near-specular pdf is unresolved, a resolvable one is not", "[sampler_test]") {
  for (double alpha : {0.3, 1e-4}) {
    std::vector<double> s, t, q;
    ggx_pilot(alpha, 20000, s, t, q);
    BinOptions o;
    o.total = 4e4;
    o.target = 600;
    o.rel_tol = 0.0;
    o.shift_tol = 0.1;
    o.max_nodes = 400'000;
    o.pilot_drawn = 20000;
    Bins b(Domain::hemisphere, o, s.data(), t.data(), s.size(), q.data());
    fill(b, Domain::hemisphere, ggx(alpha));
    double sum = 0;
    for (std::size_t i = 0; i < b.size(); ++i) sum += b.integral()[i];
    INFO("alpha " << alpha << ", integral " << sum);
    if (alpha > 0.1) {
      CHECK(b.unresolved_peaks() == 0);
      CHECK(sum == Approx(1.0).epsilon(1e-5));
    } else {  // a lobe 5e-9 wide in cos theta at the pole: the cubature finds a fraction of it
      CHECK(b.unresolved_peaks() > 0);
      CHECK(b.unresolved_reach() > o.total);
      CHECK(sum < 0.5);
    }
  }
}

TEST_CASE("a grid over resolved bins inherits their integrals and cuts cells along its edges", "[sampler_test]") {
  // The 200-lobe von Mises-Fisher style spike would need the pilot; a smooth GGX lobe and its rows of
  // 3 degrees of theta show the bookkeeping: the rows' masses add up to the bins' and each row's mass is
  // the exact GGX marginal.
  const double alpha = 0.3;
  std::vector<double> s, t, q;
  ggx_pilot(alpha, 20000, s, t, q);
  BinOptions o;
  o.total = 1e5;
  o.target = 300;
  o.rel_tol = 0.0;
  o.shift_tol = 0.1;
  o.pilot_drawn = 20000;
  Bins b(Domain::hemisphere, o, s.data(), t.data(), s.size(), q.data());
  fill(b, Domain::hemisphere, ggx(alpha));
  std::vector<double> edges{0.0};
  for (int k = 29; k >= 1; --k) edges.push_back(std::cos(k * std::numbers::pi / 60.0));
  edges.push_back(1.0);
  Bins rows(b, edges, {0.0, 1.0});
  fill(rows, Domain::hemisphere, ggx(alpha));
  REQUIRE(rows.size() == 30);
  double mass = 0, mass_rows = 0, err = 0;
  for (std::size_t i = 0; i < b.size(); ++i) mass += b.integral()[i], err += b.error()[i];
  for (std::size_t i = 0; i < rows.size(); ++i) mass_rows += rows.integral()[i], err += rows.error()[i];
  CHECK(mass_rows == Approx(mass).margin(err));
  // GGX: the mass with cos theta < z is 1 - 1 / (1 + alpha^2 (1/z^2 - 1))... as a cdf in tan^2:
  // P(tan^2 theta <= x) = x / (alpha^2 + x).
  auto cdf = [&](double z) {
    if (z <= 0.0) return 1.0;
    const double x = 1.0 / (z * z) - 1.0;
    return x / (alpha * alpha + x);
  };
  for (std::size_t k = 0; k < 30; ++k) {
    const double exact = cdf(edges[k]) - cdf(edges[k + 1]);
    CHECK(rows.integral()[k] == Approx(exact).margin(rows.error()[k] + 1e-9));
  }
  Bins pending(Domain::hemisphere, o, s.data(), t.data(), s.size(), q.data());  // no pdf values supplied yet
  CHECK_THROWS_AS(Bins(pending, {0.0, 1.0}, {0.0, 1.0}), std::logic_error);
}
