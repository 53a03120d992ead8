// Batch samplers (per-(n, p) tables) must give exactly what per-sample evaluation gives.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/stats/binomial.hpp"
#include "glintlab/stats/normal.hpp"
#include "glintlab/stats/step_inversion.hpp"

using namespace glintlab;

TEST_CASE("batch samplers equal per-sample evaluation, bit for bit", "[law][batch]") {
  // Every registered law, at regimes that exercise the table (small and large supports), its
  // fallbacks (too many steps: n = 1e15) and degenerate parameters.
  const std::vector<std::pair<double, double>> points{{16, 0.1},  {1e3, 1e-2}, {1e6, 0.3}, {1e9, 1e-6}, {10.5, 0.3},
                                                      {0.3, 0.2}, {1e15, 0.5}, {40, 0.97}, {3.7, 0.6},  {1e6, 1 - 1e-7},
                                                      {1, 0.5},   {0, 0.5},    {100, 0},   {100, 1}};
  // At every SIMD level: the AVX-512 gathers of the step tables and the scalar path must agree
  // with evaluate() alike (levels above the CPU's run its best).
  const std::size_t count = 20'000;
  std::vector<double> batch(count), direct(count);
  struct Restore {
    ~Restore() { detail::set_simd_level(2); }
  } restore;
  for (int level : {2, 0})
    for (const auto& info : registered_laws()) {
      detail::set_simd_level(level);
      const auto law = make_law(info.name);
      for (const auto& [n, p] : points) {
        if (!law->accepts(n, p)) continue;
        sample_many(*law, {&n, 1}, {&p, 1}, count, 42, batch.data());
        detail::LawKernel(*law).sample_range(n, p, 42, 0, count, direct.data());
        // Laws with their own sampler (the exact binomial's batch tabulates BTRD's final test) are
        // compared with their own sample_range.
        const detail::KernelOf kernel(*law);
        if (kernel->batch_sampler(n, p, count) == nullptr || !kernel->samples_by_evaluate())
          kernel->sample_range(n, p, 42, 0, count, direct.data());
        std::size_t mismatches = 0;
        for (std::size_t i = 0; i < count; ++i) mismatches += batch[i] != direct[i];
        INFO(info.name << " n = " << n << " p = " << p << ", SIMD level " << detail::simd_level());
        CHECK(mismatches == 0);
      }
    }
}

TEST_CASE("step tables answer exactly or not at all", "[batch]") {
  // v(u) = clamp(floor(mu + sd Phi^-1(u)), 0, top) on a fine grid of u, including u just beside
  // every threshold: the table's answer, when it gives one, is the direct value.
  const double mu = 3e5, sd = 458.0, top = 1e6;
  const auto table = floor_gaussian_steps(mu, sd, 0.0, top);
  REQUIRE(table.has_value());
  auto direct = [&](double u) { return std::clamp(std::floor(mu + sd * normal::quantile(u)), 0.0, top); };
  std::size_t answered = 0, checked = 0;
  for (double j = mu - 300; j <= mu + 300; j += 1) {
    const double t = normal::cdf((j - mu) / sd);
    for (double u : {std::nextafter(t, 0.0), t, std::nextafter(t, 1.0), t * (1 - 1e-13), t * (1 + 1e-13),
                     t * (1 - 1e-7), t * (1 + 1e-7)}) {
      const double v = (*table)(u);
      ++checked;
      if (v < 0) continue;
      ++answered;
      REQUIRE(v == direct(u));
    }
  }
  // Far from thresholds the table answers; right beside them it declines.
  CHECK(answered >= checked * 2 / 7);
  CHECK(answered < checked);
  // The vector path (sample_rows: AVX-512 gathers, here from the 16-bit cells of this 2^18-cell
  // table) on the same uniforms and on Philox rows over all of (0, 1), at every SIMD level.
  std::vector<double> u;
  for (double j = mu - 300; j <= mu + 300; j += 1) {
    const double t = normal::cdf((j - mu) / sd);
    for (double x : {std::nextafter(t, 0.0), t, std::nextafter(t, 1.0), t * (1 - 1e-7), t * (1 + 1e-7)}) u.push_back(x);
  }
  std::vector<double> more(50'000);
  fill_uniforms(5, kStreamSample, 0, more.size(), 1, more.data());
  u.insert(u.end(), more.begin(), more.end());
  std::vector<double> out(u.size());
  struct Restore {
    ~Restore() { detail::set_simd_level(2); }
  } restore;
  for (int level : {2, 0}) {
    detail::set_simd_level(level);
    table->sample_rows(u.data(), 1, 0, u.size(), StepInversion::Affine{}, out.data(),
                       [&](const double* row) { return direct(*row); });
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < u.size(); ++i) mismatches += out[i] != direct(u[i]);
    INFO("SIMD level " << detail::simd_level());
    CHECK(mismatches == 0);
  }
}

TEST_CASE("a step table without guard bands would be wrong (the check can fail)", "[batch]") {
  // Thresholds off by 1e-9 and no guards: u between the true and the shifted threshold gets the
  // wrong step, and the comparison above would catch it.
  const double mu = 50, sd = 7;
  std::vector<double> t, guard;
  for (double j = 1; j <= 100; j += 1) {
    t.push_back(normal::cdf((j - mu) / sd) + 1e-9);
    guard.push_back(0.0);
  }
  const StepInversion wrong(t, guard, 0, true, true);
  std::size_t errors = 0;
  for (double j = 30; j <= 70; j += 1) {
    const double u = normal::cdf((j - mu) / sd) + 5e-10;
    errors += wrong(u) != std::clamp(std::floor(mu + sd * normal::quantile(u)), 0.0, 100.0);
  }
  CHECK(errors > 30);
}

TEST_CASE("per-pixel evaluation equals evaluate(), bit for bit, at every SIMD level", "[law][batch][pixels]") {
  // Pixels with their own (n, p): log-uniform n over [1e-2, 1e12] plus edge values, p over
  // [1e-9, 1 - 1e-9] plus 0, 1/2, 1, on the batch uniforms (evaluate_pixels) and through sample_many's
  // per-pixel path; every law (the default loops over evaluate(), gated and head_cf have vector code).
  const std::size_t count = 60'000;
  std::vector<double> n(count), p(count), u, fast(count), direct(count);
  CounterRng rng(7, 1, 2);
  const double edge_n[] = {0, 0.3, 1, 1.5, 2, 3, 16, 1e15};
  const double edge_p[] = {0, 0.5, 1, 1e-300, 0.4999999999, 0.5000000001};
  for (std::size_t i = 0; i < count; ++i) {
    n[i] = i % 17 == 0 ? edge_n[(i / 17) % 8] : std::exp(std::log(1e-2) + rng.uniform() * std::log(1e14));
    const double t = rng.uniform();
    p[i] =
        i % 13 == 0 ? edge_p[(i / 13) % 6] : (i % 2 ? std::exp(std::log(1e-9) * t) : 1 - std::exp(std::log(1e-9) * t));
  }
  struct Restore {
    ~Restore() {
      detail::set_simd_level(2);
      set_num_threads(2);
    }
  } restore;
  for (int level : {2, 1, 0})
    for (const auto& info : registered_laws()) {
      detail::set_simd_level(level);
      const auto law = make_law(info.name);
      if (!detail::KernelOf(*law)->samples_by_evaluate()) continue;
      // Laws whose cost grows with n (explicit trial loops) get n capped at 1e4.
      const double cap = info.traits.constant_time ? 1e300 : 1e4;
      std::vector<double> nn, pp;
      for (std::size_t i = 0; i < count; ++i)
        if (law->accepts(std::min(n[i], cap), p[i])) {
          nn.push_back(std::min(n[i], cap));
          pp.push_back(p[i]);
        }
      const std::size_t m = nn.size(), k = static_cast<std::size_t>(law->n_uniforms());
      u.assign(m * std::max<std::size_t>(k, 1), 0.0);
      fill_uniforms(42, kStreamSample, 0, m, static_cast<int>(k), u.data());
      detail::KernelOf(*law)->evaluate_pixels(nn.data(), pp.data(), u.data(), m, fast.data());
      for (std::size_t i = 0; i < m; ++i) direct[i] = law->evaluate(nn[i], pp[i], u.data() + i * k);
      std::size_t mismatches = 0;
      for (std::size_t i = 0; i < m; ++i)
        mismatches += !(fast[i] == direct[i] || (std::isnan(fast[i]) && std::isnan(direct[i])));
      INFO(info.name << ", SIMD level " << detail::simd_level() << ", " << m << " pixels");
      CHECK(mismatches == 0);
      for (int threads : {1, 2}) {  // sample_many's per-pixel path: same output at any thread count
        set_num_threads(threads);
        sample_many(*law, {nn.data(), m}, {pp.data(), m}, m, 42, fast.data());
        mismatches = 0;
        for (std::size_t i = 0; i < m; ++i)
          mismatches += !(fast[i] == direct[i] || (std::isnan(fast[i]) && std::isnan(direct[i])));
        INFO("sample_many, " << threads << " threads");
        CHECK(mismatches == 0);
      }
    }
}

TEST_CASE("the exact binomial's prefetched Philox rows give the scalar generator's draws", "[law][batch][pixels]") {
  // sample_range and the per-pixel path take each sample's first Philox block from the vector rows
  // (binomial::PrefetchedRng); the draws must be those of binomial::Sampler on CounterRng::for_index,
  // including the samples that need more than two uniforms (BTRD rejections, the fractional facet).
  const auto law = make_law("binomial");
  const std::vector<std::pair<double, double>> points{{16, 0.1},   {1e3, 1e-2}, {1e6, 0.3}, {1e9, 1e-6}, {40.5, 0.7},
                                                      {1e15, 0.5}, {0.5, 0.5},  {100, 0},   {100, 1}};
  const std::size_t count = 5000;
  std::vector<double> got(count);
  struct Restore {
    ~Restore() {
      detail::set_simd_level(2);
      set_num_threads(2);
    }
  } restore;
  for (int level : {2, 1, 0}) {
    detail::set_simd_level(level);
    for (const auto& [n, p] : points) {
      for (bool table : {false, true}) {
        const binomial::Sampler sampler(n, p, table);
        const std::size_t m = table ? count : 40;  // sample_range tabulates from kTabulateMinBatch rows
        detail::KernelOf(*law)->sample_range(n, p, 9, 100, 100 + m, got.data());
        std::size_t mismatches = 0;
        for (std::size_t i = 0; i < m; ++i) {
          auto rng = CounterRng::for_index(9, 100 + i, kStreamSample);
          mismatches += got[i] != sampler(rng);
        }
        INFO("n = " << n << " p = " << p << ", SIMD level " << detail::simd_level());
        CHECK(mismatches == 0);
      }
    }
    // Pixels, each its own (n, p), at 1 and 2 threads.
    std::vector<double> n(count), p(count);
    CounterRng pick(3, 4, 5);
    for (std::size_t i = 0; i < count; ++i) {
      n[i] = std::floor(std::exp(pick.uniform() * std::log(1e12))) + (i % 3 == 0 ? 0.5 : 0.0);
      p[i] = pick.uniform();
    }
    for (int threads : {1, 2}) {
      set_num_threads(threads);
      sample_many(*law, {n.data(), count}, {p.data(), count}, count, 11, got.data());
      std::size_t mismatches = 0;
      for (std::size_t i = 0; i < count; ++i) {
        auto rng = CounterRng::for_index(11, i, kStreamSample);
        mismatches += got[i] != binomial::Sampler(n[i], p[i])(rng);
      }
      INFO("pixels, " << threads << " threads, SIMD level " << detail::simd_level());
      CHECK(mismatches == 0);
    }
  }
}

TEST_CASE("the vector per-pixel kernels hand their unsure pixels to evaluate()", "[law][batch][pixels]") {
  // Explicit uniforms where the kernels' shortcuts could decide wrongly: the gate uniform on (and a
  // few ulps beside) the gate probability P1 = -expm1(n log1p(-p)), including tiny P1 where the
  // kernel's 1 - exp(x) loses relative precision; the count uniform in the far tails (within e^-25
  // of 0 or 1, where the kernels do not evaluate AS 241's third region), at the central/tail border
  // and on the steps of the Gaussian count. Every pixel must equal evaluate().
  std::vector<double> n, p, u;
  const double ns[] = {1e-3, 0.5, 1, 1.5, 2, 7.3, 16, 1e3, 1e6, 1e12};
  const double ps[] = {1e-300, 1e-17, 1e-9, 1e-6, 0.01, 0.3, 0.5, 0.7, 1 - 1e-9};
  const double tails[] = {1e-300,       1e-100, 1e-13, 1.5e-11,  1e-9,      0.075,
                          0.0750000001, 0.5,    0.925, 1 - 1e-9, 1 - 1e-13, 1 - 1.5e-11};
  for (double nv : ns)
    for (double pv : ps) {
      const double p1 = -std::expm1(nv * std::log1p(-pv));
      std::vector<double> gates{0.5, std::nextafter(1.0, 0.0)};
      if (p1 > 0) {
        double g = p1;
        for (int k = 0; k < 3; ++k) g = std::nextafter(g, 0.0);
        for (int k = 0; k < 7; ++k, g = std::nextafter(g, 1.0)) gates.push_back(g);
        gates.push_back(p1 * (1 - 1e-12));
        gates.push_back(p1 * 0.5);
        // Just outside the kernels' gate band (1e-8 absolute): decided from their own cheap P1.
        for (double d : {-1.5e-8, 1.5e-8, -1e-7, 1e-7}) gates.push_back(p1 + d);
      }
      for (double g : gates)
        for (double t : tails) {
          if (!(g > 0 && g < 1)) continue;
          n.push_back(nv);
          p.push_back(pv);
          u.push_back(g);
          u.push_back(t);
        }
    }
  // Count uniforms on the steps of the Gaussian count at (1e3, 0.01): floor(mu + sigma z) = j.
  const double mu = 999 * 0.01, sigma = std::sqrt(mu * 0.99);
  for (double j = 0; j <= 30; j += 1)
    for (double d : {-1e-13, 0.0, 1e-13}) {
      n.push_back(1e3);
      p.push_back(0.01);
      u.push_back(0.5 * 1e-3);  // gated
      u.push_back(normal::cdf((j - mu) / sigma) + d);
    }
  // ... and in both tails at (1e6, 0.3) (sigma = 458): steps a relative 1e-9 to 1e-6 of u beside
  // the exact thresholds, inside and outside the kernels' count band.
  const double mu6 = (1e6 - 1) * 0.3, sigma6 = std::sqrt(mu6 * 0.7);
  for (double zj : {-4.5, -3.0, -1.5, 1.5, 3.0, 4.5})
    for (double d : {-1e-6, -1e-8, -1e-9, 1e-9, 1e-8, 1e-6}) {
      const double j = std::floor(mu6 + sigma6 * zj);
      n.push_back(1e6);
      p.push_back(0.3);
      u.push_back(0.5);  // gated (P1 = 1)
      u.push_back(normal::cdf((j - mu6) / sigma6) * (1 + d));
    }
  const std::size_t m = n.size();
  std::vector<double> fast(m);
  struct Restore {
    ~Restore() { detail::set_simd_level(2); }
  } restore;
  for (int level : {2, 1, 0})
    for (const char* name : {"gated", "head_cf"}) {
      detail::set_simd_level(level);
      const auto law = make_law(name);
      detail::KernelOf(*law)->evaluate_pixels(n.data(), p.data(), u.data(), m, fast.data());
      std::size_t mismatches = 0;
      for (std::size_t i = 0; i < m; ++i) {
        const double direct = law->evaluate(n[i], p[i], u.data() + 2 * i);
        mismatches += !(fast[i] == direct || (std::isnan(fast[i]) && std::isnan(direct)));
      }
      INFO(name << ", SIMD level " << detail::simd_level() << ", " << m << " pixels");
      CHECK(mismatches == 0);
    }
}
