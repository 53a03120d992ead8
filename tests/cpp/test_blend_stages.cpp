// The four stages of a blend call (glintlab/detail/blend_stages.hpp), each against its own contract: brackets hold
// the area between their levels with weights that split it; trial counts are integral where they stand for
// integers, in range and refused above the inner law's domain; level rows are the inner law on the uniforms keyed by
// (seed, row, level) alone, whatever the chunk; combine is each rule's formula. Then the seed followed through the
// four stages by hand gives BlendedLaw::sample and sample_at bit for bit.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "glintlab/counting/blend.hpp"
#include "glintlab/detail/blend_stages.hpp"

using namespace glintlab;
namespace stages = glintlab::detail::blend_stages;

namespace {

std::shared_ptr<const CountingLaw> law_named(const std::string& name) {
  return std::shared_ptr<const CountingLaw>(make_law(name));
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Log-uniform footprint areas over [lo, hi) from a fixed-seed generator, with a few on levels and an ulp either side.
std::vector<double> footprints(double lo, double hi, std::size_t m, std::uint64_t seed) {
  std::vector<double> a(m);
  CounterRng rng(seed, 0, 0);
  for (double& x : a) x = lo * std::exp(std::log(hi / lo) * rng.uniform());
  for (double level : {1.0, 4.0, 16.0, 256.0, 1024.0}) {
    if (!(level >= lo && level < hi)) continue;
    a.push_back(level);
    a.push_back(std::nextafter(level, 0.0));
    a.push_back(std::nextafter(level, INFINITY));
  }
  return a;
}

// The rows of one chunk after stages 1 and 2, owning their buffers.
struct StagedRows {
  std::vector<double> areas, t_lo, t_hi;
  std::vector<LevelBracket> brackets;
  stages::ChunkRows rows;
  StagedRows(const BlendRule& rule, const LevelLadder& ladder, double density, std::vector<double> a, ParamArray p,
             std::size_t i0, const CountingLaw* law)
      : areas(std::move(a)), t_lo(areas.size()), t_hi(areas.size()), brackets(areas.size()) {
    const std::size_t m = areas.size();
    REQUIRE(stages::bracket_rows(ladder, rule.reads_lod_weight(), false, areas.data(), p, i0, m, brackets.data()) == m);
    rows.i0 = i0;
    rows.m = m;
    rows.areas = areas.data();
    rows.brackets = brackets.data();
    rows.trials[0] = t_lo.data();
    rows.trials[1] = t_hi.data();
    rows.p = p;
    REQUIRE(stages::trial_counts(rule, density, areas.data(), brackets.data(), m, law, t_lo.data(), t_hi.data(),
                                 rows.span) == m);
  }
};

}  // namespace

TEST_CASE("stage 1: each bracket holds its area between its levels, and its weights split it", "[blend][stages]") {
  for (double ratio : {4.0, 2.0, 1.5}) {
    const LevelLadder ladder(ratio, 0.25);
    const std::vector<double> a = footprints(1e-3, 1e4, 2000, 3);
    const double p = 0.1;
    for (bool with_lod : {true, false}) {
      std::vector<LevelBracket> b(a.size());
      REQUIRE(stages::bracket_rows(ladder, with_lod, false, a.data(), {&p, 1}, 0, a.size(), b.data()) == a.size());
      for (std::size_t r = 0; r < a.size(); ++r) {
        INFO("ratio " << ratio << " P " << a[r] << " with_lod " << with_lod);
        CHECK(b[r].area_lo == ladder.area(b[r].lo));
        CHECK(b[r].area_hi == ladder.area(b[r].lo + 1));
        CHECK(b[r].area_lo <= a[r]);
        CHECK(a[r] < b[r].area_hi);
        // DB23 eq. 10's weights: (1 - w) and w of the two levels sum to one and split P between the levels' areas.
        CHECK(b[r].w_area >= 0.0);
        CHECK(b[r].w_area < 1.0);
        CHECK((1 - b[r].w_area) * b[r].area_lo + b[r].w_area * b[r].area_hi == Approx(a[r]).epsilon(1e-12));
        const LevelBracket exact = ladder.bracket(a[r]);
        CHECK(b[r].lo == exact.lo);
        CHECK(same_bits(b[r].w_area, exact.w_area));
        if (with_lod) {
          CHECK(same_bits(b[r].w_lod, exact.w_lod));
          CHECK(b[r].w_lod >= 0.0);
          CHECK(b[r].w_lod < 1.0);
        } else {
          CHECK(std::isnan(b[r].w_lod));  // a rule that does not read it is spared the logarithm
        }
      }
    }
  }
}

TEST_CASE("stage 1: the first refused row is named, and nothing is bracketed before it is found", "[blend][stages]") {
  const LevelLadder ladder(4, 1);
  std::vector<double> a(300, 2.0), p(300, 0.1);
  std::vector<LevelBracket> b(a.size());
  CHECK(stages::bracket_rows(ladder, true, false, a.data(), {p.data(), p.size()}, 0, a.size(), b.data()) == 300);
  a[200] = std::numeric_limits<double>::quiet_NaN();
  p[250] = 1.5;
  CHECK(stages::bracket_rows(ladder, true, false, a.data(), {p.data(), p.size()}, 0, a.size(), b.data()) == 200);
  // A level index beyond 16 bits (log(1e300) / log(1.001) is 691 000 levels): refused by the ladder itself, also
  // before a row the checks refuse.
  const LevelLadder fine(1.001, 1);
  CHECK(stages::bracket_rows(fine, true, false, a.data(), {p.data(), p.size()}, 0, a.size(), b.data()) == 200);
  a[120] = 1e300;
  CHECK(stages::bracket_rows(fine, true, false, a.data(), {p.data(), p.size()}, 0, a.size(), b.data()) == 120);
  a[200] = 2.0;
  p[250] = 0.1;
  CHECK(stages::bracket_rows(fine, true, false, a.data(), {p.data(), p.size()}, 0, a.size(), b.data()) == 120);
  CHECK(stages::bracket_rows(ladder, true, false, a.data(), {p.data(), p.size()}, 0, a.size(), b.data()) == 300);
  // p is the call's array: row r reads p[i0 + r].
  p[250] = 1.5;
  std::vector<double> ok(10, 2.0);
  CHECK(stages::bracket_rows(ladder, true, false, ok.data(), {p.data(), p.size()}, 245, 10, b.data()) == 5);
  const double zero = 0.0;
  CHECK(stages::bracket_rows(ladder, true, true, &zero, {p.data(), p.size()}, 0, 3, b.data()) == 0);
}

TEST_CASE("stage 2: trial counts are integral where they stand for integers, in range, and checked",
          "[blend][stages]") {
  const LevelLadder ladder(4, 1);
  const double p = 0.05;
  const auto gated = law_named("gated");
  for (const std::string name : {"distributed", "zk16_linear", "nearest", "roulette"}) {
    const auto rule = make_blend(name);
    for (const double density : {1e4, 37.3}) {
      StagedRows staged(*rule, ladder, density, footprints(0.5, 2000, 1500, 4), {&p, 1}, 0, gated.get());
      const stages::ChunkRows& rows = staged.rows;
      int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
      for (std::size_t r = 0; r < rows.m; ++r) {
        const LevelBracket& b = rows.bracket(r);
        const double t[2] = {rows.trial(0, r), rows.trial(1, r)};
        const double full[2] = {density * b.area_lo, density * b.area_hi};
        INFO(name << " N " << density << " P " << rows.areas[r]);
        for (int j = 0; j < 2; ++j) {
          CHECK(t[j] >= 0.0);
          CHECK(t[j] <= full[j]);
          // N A_l is an integer at N = 1e4 (areas 4^l): the rules that draw whole levels draw it exactly.
          if (density == 1e4 && name != "distributed" && t[j] > 0) CHECK(t[j] == full[j]);
        }
        // distributed splits N P between the levels: its counts sum to N P.
        if (name == "distributed") CHECK(t[0] + t[1] == Approx(density * rows.areas[r]).epsilon(1e-12));
        if (name == "nearest") CHECK(((t[0] > 0) != (t[1] > 0)));
        if (t[0] > 0 || t[1] > 0) {
          lo = std::min(lo, b.lo + (t[0] > 0 ? 0 : 1));
          hi = std::max(hi, b.lo + (t[1] > 0 ? 1 : 0));
        }
      }
      CHECK(rows.span.lo == lo);
      CHECK(rows.span.hi == hi);
    }
  }
  // A count a few ulps off the integer it stands for is that integer: N A_hi at P one ulp below A_hi, w ~ 1.
  const auto distributed = make_blend("distributed");
  StagedRows staged(*distributed, ladder, 3.0, {std::nextafter(16.0, 0.0)}, {&p, 1}, 0, gated.get());
  CHECK(staged.rows.trial(0, 0) + staged.rows.trial(1, 0) == 48.0);
  CHECK(staged.rows.trial(1, 0) == std::floor(staged.rows.trial(1, 0)));
  // Above the inner law's domain: the first such row is refused.
  std::vector<double> a(20, 2.0), t_lo(20), t_hi(20);
  a[13] = 1e17;
  std::vector<LevelBracket> b(a.size());
  REQUIRE(stages::bracket_rows(ladder, true, false, a.data(), {&p, 1}, 0, a.size(), b.data()) == a.size());
  stages::LevelSpan span;
  CHECK(stages::trial_counts(*distributed, 1e3, a.data(), b.data(), a.size(), gated.get(), t_lo.data(), t_hi.data(),
                             span) == 13);
  CHECK(stages::trial_counts(*distributed, 1e3, a.data(), b.data(), a.size(), nullptr, t_lo.data(), t_hi.data(),
                             span) == a.size());  // no law, no domain
}

TEST_CASE("stage 3: a row's level counts are the inner law on its (seed, row, level) uniforms, whatever the chunk",
          "[blend][stages]") {
  const LevelLadder ladder(4, 1);
  const std::uint64_t seed = 41;
  const stages::RowStreams streams = stages::RowStreams::index_cells(seed);
  for (const std::string inner_name : {"gated", "binomial"}) {
    const auto law = law_named(inner_name);
    const InnerLaw inner = InnerLaw::from_law(law);
    const std::size_t k = static_cast<std::size_t>(law->n_uniforms());
    for (const std::string rule_name : {"zk16_linear", "distributed", "nearest"}) {
      const auto rule = make_blend(rule_name);
      // Rows i0 .. i0 + m of a call whose p is an array (row r's p is p[i0 + r]).
      std::vector<double> p(6000);
      for (std::size_t i = 0; i < p.size(); ++i) p[i] = i % 3 == 0 ? 0.02 : 0.01;
      const std::size_t i0 = 5000, m = 700;
      StagedRows staged(*rule, ladder, 1e3, footprints(0.3, 60, m, 5), {p.data(), p.size()}, i0, law.get());
      const stages::ChunkRows& rows = staged.rows;
      std::vector<double> k_lo(rows.m), k_hi(rows.m);
      stages::LevelEvaluators evaluators;
      stages::ChunkScratch scratch;
      stages::level_counts(inner, ladder, streams, rows, evaluators, rows.m, "test", scratch, k_lo.data(), k_hi.data());
      // The reference: evaluate() on the first k numbers of CounterRng(seed, cell of row i0 + r, level) per row.
      std::vector<double> u(k);
      for (std::size_t r = 0; r < rows.m; ++r) {
        for (int j = 0; j < 2; ++j) {
          const double t = rows.trial(j, r), got = j == 0 ? k_lo[r] : k_hi[r];
          INFO(inner_name << " " << rule_name << " row " << r << " level slot " << j);
          if (!(t > 0)) {
            CHECK(got == 0.0);
            continue;
          }
          CounterRng rng(seed, static_cast<std::uint32_t>(i0 + r), 0, stages::level_key(rows.bracket(r).lo + j),
                         kStreamLevelCount);
          for (double& x : u) x = rng.uniform();
          CHECK(same_bits(got, law->evaluate(t, p[i0 + r], u.data())));
        }
      }
      // A different seed draws different counts: the seed reaches them (through RowStreams only).
      std::vector<double> other_lo(rows.m), other_hi(rows.m);
      stages::level_counts(inner, ladder, stages::RowStreams::index_cells(seed + 1), rows, evaluators, rows.m, "test",
                           scratch, other_lo.data(), other_hi.data());
      CHECK(other_lo != k_lo);
    }
  }
}

TEST_CASE("stage 3: positioned rows in one level cell share its count, and one footprint draws what rows do",
          "[blend][stages]") {
  const LevelLadder ladder(4, 1);
  const auto law = law_named("gated");
  const InnerLaw inner = InnerLaw::from_law(law);
  const auto rule = make_blend("zk16_linear");
  const double p = 0.05;
  // Positions 0.1 apart: cells of side 2 and 4 (levels 1, 2) hold many rows each.
  std::vector<double> x(400), y(400, 0.5);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 0.1 * static_cast<double>(i);
  const stages::RowStreams streams = stages::RowStreams::positions(3, {x.data(), x.size()}, {y.data(), y.size()});
  StagedRows staged(*rule, ladder, 1e3, std::vector<double>(x.size(), 8.0), {&p, 1}, 0, law.get());
  std::vector<double> k_lo(x.size()), k_hi(x.size());
  stages::LevelEvaluators evaluators;
  stages::ChunkScratch scratch;
  stages::level_counts(inner, ladder, streams, staged.rows, evaluators, x.size(), "test", scratch, k_lo.data(),
                       k_hi.data());
  for (std::size_t i = 1; i < x.size(); ++i) {
    if (std::floor(x[i] / 2) == std::floor(x[i - 1] / 2)) CHECK(k_lo[i] == k_lo[i - 1]);
    if (std::floor(x[i] / 4) == std::floor(x[i - 1] / 4)) CHECK(k_hi[i] == k_hi[i - 1]);
  }
  CHECK(std::set<double>(k_lo.begin(), k_lo.end()).size() > 5);
  // The same rows as one footprint (one shared bracket and pair of trials): the same counts.
  stages::ChunkRows one = staged.rows;
  one.step = 0;
  std::vector<double> one_lo(x.size()), one_hi(x.size());
  stages::level_counts(inner, ladder, streams, one, evaluators, x.size(), "test", scratch, one_lo.data(),
                       one_hi.data());
  CHECK(one_lo == k_lo);
  CHECK(one_hi == k_hi);
}

TEST_CASE("stage 4: combine is each rule's formula on the level counts", "[blend][stages]") {
  const LevelLadder ladder(4, 1);
  const double p = 0.05;
  const auto law = law_named("gated");
  const stages::RowStreams streams = stages::RowStreams::index_cells(8);
  for (const std::string name : {"distributed", "zk16_linear", "nearest", "roulette", "roulette_hard"}) {
    const bool hard = name == "roulette_hard";
    const auto rule = hard ? make_blend("roulette", {{"epsilon", 0.0}}) : make_blend(name);
    StagedRows staged(*rule, ladder, 1e3, footprints(0.3, 60, 900, 6), {&p, 1}, 0, law.get());
    const stages::ChunkRows& rows = staged.rows;
    std::vector<double> k_lo(rows.m), k_hi(rows.m), out(rows.m);
    for (std::size_t r = 0; r < rows.m; ++r) {  // counts near each level's mean, some levels undrawn
      k_lo[r] = rows.trial(0, r) > 0 ? std::floor(rows.trial(0, r) * p + static_cast<double>(r % 7)) : 0.0;
      k_hi[r] = rows.trial(1, r) > 0 ? std::floor(rows.trial(1, r) * p + static_cast<double>(r % 5)) : 0.0;
    }
    stages::ChunkScratch scratch;
    stages::combine_levels(*rule, streams, rows, k_lo.data(), k_hi.data(), scratch, out.data());
    for (std::size_t r = 0; r < rows.m; ++r) {
      const LevelBracket& b = rows.bracket(r);
      const double P = rows.areas[r], w = b.w_lod;
      INFO(name << " P " << P << " k " << k_lo[r] << ", " << k_hi[r]);
      if (name == "distributed") CHECK(out[r] == k_lo[r] + k_hi[r]);
      if (name == "zk16_linear")
        CHECK(out[r] == Approx(P * ((1 - w) * k_lo[r] / b.area_lo + w * k_hi[r] / b.area_hi)).epsilon(1e-12));
      if (name == "nearest")
        CHECK(out[r] == Approx(w >= 0.5 ? P / b.area_hi * k_hi[r] : P / b.area_lo * k_lo[r]).epsilon(1e-12));
      if (name.starts_with("roulette")) {
        // Each level's kept facets are at most its count, scaled by P / A_l; the hard roulette keeps whole facets.
        CHECK(out[r] >= 0.0);
        CHECK(out[r] <= P / b.area_lo * k_lo[r] + P / b.area_hi * k_hi[r] + 1e-9);
        // combine() per row on the row's own facet streams, from their start: the same bits.
        std::array<FacetStream, 2> facets = {streams.facets(r, b.lo, b.area_lo, nullptr),
                                             streams.facets(r, b.lo + 1, b.area_hi, nullptr)};
        CHECK(same_bits(out[r], rule->combine(P, b, k_lo[r], k_hi[r], facets)));
      }
    }
  }
}

TEST_CASE("the seed followed through the four stages by hand is BlendedLaw::sample and sample_at", "[blend][stages]") {
  const LevelLadder ladder(4, 1);
  const double density = 2e3, p = 0.02;
  for (const std::string name : {"distributed", "zk16_linear", "nearest", "roulette"}) {
    for (const std::string inner_name : {"gated", "binomial"}) {
      const auto law = law_named(inner_name);
      const BlendedLaw blend(make_blend(name), InnerLaw::from_law(law), ladder);
      const std::uint64_t seed = 77;
      const std::size_t count = 3000;
      const std::vector<double> areas = footprints(0.5, 40, count, 9);
      std::vector<double> x(areas.size()), y(areas.size());
      for (std::size_t i = 0; i < x.size(); ++i) {
        x[i] = 0.37 * static_cast<double>(i % 97);
        y[i] = 0.53 * static_cast<double>(i / 97);
      }
      for (const bool positioned : {false, true}) {
        const stages::RowStreams streams =
            positioned ? stages::RowStreams::positions(seed, {x.data(), x.size()}, {y.data(), y.size()})
                       : stages::RowStreams::index_cells(seed);
        // Stages 1 and 2, then 3 (the seed: count uniforms), then 4 (the seed: facet streams), one chunk of all rows.
        StagedRows staged(blend.rule(), ladder, density, areas, {&p, 1}, 0, law.get());
        std::vector<double> k_lo(areas.size()), k_hi(areas.size()), by_hand(areas.size()), sampled(areas.size());
        stages::LevelEvaluators evaluators;
        stages::ChunkScratch scratch;
        stages::level_counts(blend.inner(), ladder, streams, staged.rows, evaluators, areas.size(), "test", scratch,
                             k_lo.data(), k_hi.data());
        stages::combine_levels(blend.rule(), streams, staged.rows, k_lo.data(), k_hi.data(), scratch, by_hand.data());
        if (positioned)
          blend.sample_at(density, {areas.data(), areas.size()}, {&p, 1}, {x.data(), x.size()}, {y.data(), y.size()},
                          areas.size(), seed, sampled.data());
        else
          blend.sample(density, {areas.data(), areas.size()}, {&p, 1}, areas.size(), seed, sampled.data());
        INFO(name << "[" << inner_name << "] positioned " << positioned);
        CHECK(std::memcmp(by_hand.data(), sampled.data(), by_hand.size() * sizeof(double)) == 0);
      }
    }
  }
}

TEST_CASE("a call names its lowest bad sample, a level index beyond 16 bits before a NaN footprint",
          "[blend][stages]") {
  // Stage 1 found the NaN at 200 and stopped before the ladder saw row 120 (the call then named 200).
  const BlendedLaw blend(make_blend("distributed"), InnerLaw::from_law(law_named("gated")), LevelLadder(1.001, 1));
  std::vector<double> P(300, 2.0), out(P.size());
  P[120] = 1e300;
  P[200] = std::numeric_limits<double>::quiet_NaN();
  const double p = 0.1;
  CHECK_THROWS_WITH(blend.sample(10, {P.data(), P.size()}, {&p, 1}, P.size(), 1, out.data()),
                    Catch::Contains("32767 levels"));
}

TEST_CASE("stage 3's evaluators are kept across calls without changing a bit", "[blend][stages]") {
  // LevelEvaluators: an (n, p) kept for as many rows or more is reused; one built for fewer rows (perhaps without a
  // step table) is replaced.
  const auto law = law_named("gated");
  const InnerLaw inner = InnerLaw::from_law(law);
  stages::LevelEvaluators kept;
  const auto big = kept.get(inner, 2.56e6, 0.01, 1000000);
  CHECK(kept.get(inner, 2.56e6, 0.01, 1000) == big);
  CHECK(kept.get(inner, 2.56e6, 0.01, 1000000) == big);
  const auto small = kept.get(inner, 4e4, 0.01, 100);
  const auto larger = kept.get(inner, 4e4, 0.01, 100000);
  CHECK(larger != small);
  CHECK(kept.get(inner, 4e4, 0.01, 5000) == larger);
  CHECK(kept.get(inner, 4e4, 0.02, 5000) != larger);
  CHECK(kept.size() == 3);
  // A blend called again (at hundreds of base cells: two 2^18-cell tables), with fewer and with more rows, draws what
  // a fresh blend draws.
  for (const std::string name : {"roulette", "zk16_linear", "distributed"}) {
    const BlendedLaw reused(make_blend(name), inner, LevelLadder(4, 1));
    const double p = 0.01;
    for (const double P : {409.0, 8.0, 409.0})
      for (const std::size_t count : {std::size_t{200000}, std::size_t{3000}, std::size_t{100}, std::size_t{300000}}) {
        const BlendedLaw fresh(make_blend(name), inner, LevelLadder(4, 1));
        std::vector<double> a(count), b(count);
        reused.sample(1e4, {&P, 1}, {&p, 1}, count, 5, a.data());
        fresh.sample(1e4, {&P, 1}, {&p, 1}, count, 5, b.data());
        INFO(name << " P " << P << " count " << count);
        CHECK(std::memcmp(a.data(), b.data(), count * sizeof(double)) == 0);
      }
  }
}
