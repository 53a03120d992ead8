// The stages of AnisoCounter (glintlab/detail/aniso_stages.hpp), each against its own contract: footprint terms are the
// scheme's (none for a bad footprint); a term's cells are the lattice vertices with weights that sum to the term's
// scale (or one picked vertex of them), keyed by the pixel's grid seed; evaluate is the inner law on each cell's own
// uniforms, grouped by term or not; accumulate sums each pixel's weighted counts. Then the seed followed through the
// stages by hand gives count_pixels bit for bit.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "glintlab/counting/aniso.hpp"
#include "glintlab/detail/aniso_stages.hpp"
#include "glintlab/detail/law_kernel.hpp"

using namespace glintlab;
using namespace glintlab::aniso;
namespace stages = glintlab::detail::aniso_stages;

namespace {

constexpr double kDensity = 1024.0 * 1024.0;

std::shared_ptr<const GridScheme> scheme_named(const std::string& name) {
  return std::shared_ptr<const GridScheme>(make_grid_scheme(name, {{"base_area", 1.0 / kDensity}}));
}

const std::vector<CounterOptions> kOptions = {
    {Spatial::kNone, Angular::kNone, Realization::kSelect},
    {Spatial::kSquare, Angular::kNone, Realization::kBlend},
    {Spatial::kSimplex, Angular::kBilinear, Realization::kBlend},
    {Spatial::kSquare, Angular::kBilinear, Realization::kSelect},
};

int rows_per_term(const CounterOptions& o) {
  if (o.realization == Realization::kSelect) return 1;
  return (o.spatial == Spatial::kNone     ? 1
          : o.spatial == Spatial::kSquare ? 4
                                          : 3) *
         (o.angular == Angular::kNone ? 1 : 4);
}

}  // namespace

TEST_CASE("aniso stage 1: a footprint's terms are the scheme's, none for a bad footprint", "[aniso][stages]") {
  const auto scheme = scheme_named("zk16_aniso");
  std::vector<Term> terms, expected;
  ShapeStatus status;
  const Shape ok = shape_from_params(3e-5, 4.5, 0.7);
  REQUIRE(stages::footprint_terms(*scheme, kDensity, ok, nullptr, terms, status));
  CHECK(!scheme->terms(ok, kDensity, expected));
  CHECK(terms.size() == expected.size());
  CHECK(status == ShapeStatus::kOk);
  // Beyond the scheme's cap the footprint is widened: clamped.
  REQUIRE(stages::footprint_terms(*scheme, kDensity, shape_from_params(3e-5, 400.0, 0.7), nullptr, terms, status));
  CHECK(status == ShapeStatus::kClamped);
  for (const Shape& bad : {shape_from_jacobian(0, 0, 0, 0), shape_from_jacobian(NAN, 0, 0, 1)}) {
    CHECK(!stages::footprint_terms(*scheme, kDensity, bad, nullptr, terms, status));
    CHECK(terms.empty());
    CHECK(status == bad.status);
  }
  // Shared terms (sample()): the call's, whatever the shape passed.
  std::vector<Term> shared(3);
  shared[1].trials = 7;
  terms.clear();
  REQUIRE(stages::footprint_terms(*scheme, kDensity, ok, &shared, terms, status));
  CHECK(terms.size() == 3);
  CHECK(terms[1].trials == 7);
}

TEST_CASE("aniso stage 2: a term's cells are its lattice vertices, weighted to its scale, keyed by the grid seed",
          "[aniso][stages]") {
  const auto scheme = scheme_named("db23_trilinear");
  std::vector<Term> terms;
  scheme->terms(shape_from_params(2e-5, 3.3, 0.4), kDensity, terms);
  REQUIRE(!terms.empty());
  for (const CounterOptions& options : kOptions) {
    const auto per_term = static_cast<std::size_t>(rows_per_term(options));
    stages::CellRows rows, blended;
    rows.ensure_rows(terms.size() * per_term, 2);
    stages::TermCells cells(options, terms.size());
    CounterOptions blend_options = options;
    blend_options.realization = Realization::kBlend;
    stages::TermCells all(blend_options, terms.size());
    blended.ensure_rows(terms.size() * 16, 2);
    for (std::size_t px_i = 0; px_i < 50; ++px_i) {
      const stages::Pixel px{
          0.013 * static_cast<double>(px_i), 0.37, 1.3 + 0.1 * static_cast<double>(px_i), -0.6, 0.1, 99, 1234};
      std::size_t at = 0;
      for (std::size_t ti = 0; ti < terms.size(); ++ti) {
        const std::size_t added = cells.gather(px, px_i, ti, terms[ti], rows, at);
        INFO("spatial " << spatial_name(options.spatial) << " angular " << angular_name(options.angular) << " "
                        << realization_name(options.realization) << " term " << ti);
        REQUIRE(added == per_term);
        double weight = 0;
        for (std::size_t q = at; q < at + added; ++q) {
          weight += rows.coef[q];
          CHECK(rows.n[q] == terms[ti].trials);
          CHECK(rows.p[q] == 0.1);
          CHECK(rows.owner[q] == px_i);
          CHECK(rows.term[q] == ti);
        }
        CHECK(weight == Approx(terms[ti].scale).epsilon(1e-12));  // the interpolation weights partition unity
        // A picked cell is one of the blended realization's cells (same keys).
        const std::size_t n_all = all.gather(px, px_i, ti, terms[ti], blended, 0);
        const std::set<std::uint64_t> keys(blended.cell.begin(), blended.cell.begin() + static_cast<long>(n_all));
        for (std::size_t q = at; q < at + added; ++q) CHECK(keys.count(rows.cell[q]) == 1);
        at += added;
      }
    }
  }
  // The keys are the grid seed's: another seed, other cells; the same seed at the same position, the same cells.
  const CounterOptions options{Spatial::kSquare, Angular::kNone, Realization::kBlend};
  stages::CellRows a, b, c;
  for (auto* r : {&a, &b, &c}) r->ensure_rows(4, 2);
  stages::TermCells ca(options, 1), cb(options, 1), cc(options, 1);
  const stages::Pixel px{0.2, 0.3, 0, 0, 0.1, 5, 6}, other{0.2, 0.3, 0, 0, 0.1, 7, 6};
  ca.gather(px, 0, 0, terms[0], a, 0);
  cb.gather(px, 3, 0, terms[0], b, 0);
  cc.gather(other, 0, 0, terms[0], c, 0);
  CHECK(std::vector<std::uint64_t>(a.cell.begin(), a.cell.begin() + 4) ==
        std::vector<std::uint64_t>(b.cell.begin(), b.cell.begin() + 4));
  CHECK(std::vector<std::uint64_t>(a.cell.begin(), a.cell.begin() + 4) !=
        std::vector<std::uint64_t>(c.cell.begin(), c.cell.begin() + 4));
}

TEST_CASE("aniso stage 3: each row's count is the inner law on its cell's uniforms, grouped by term or not",
          "[aniso][stages]") {
  for (const std::string name : {"gated", "binomial"}) {
    const std::shared_ptr<const CountingLaw> law(make_law(name));
    const InnerLaw inner = InnerLaw::from_law(law);
    const auto nu = static_cast<std::size_t>(law->n_uniforms());
    const std::size_t count = 600, terms = 3;
    const double trials[terms] = {40.0, 1e4, 0.0};
    stages::CellRows rows;
    rows.ensure_rows(count, nu);
    for (std::size_t q = 0; q < count; ++q) {
      rows.term[q] = static_cast<std::uint32_t>(q % terms);
      rows.n[q] = trials[q % terms];
      rows.p[q] = 0.05;
      rows.cell[q] = 0x9E3779B97F4A7C15ULL * (q + 1);
      rows.owner[q] = q / terms;
      rows.coef[q] = 1.0;
    }
    stages::evaluate_cells(inner, nullptr, rows, count);
    const std::vector<double> per_pixel(rows.k.begin(), rows.k.begin() + static_cast<long>(count));
    std::vector<double> u(nu);
    for (std::size_t q = 0; q < count; ++q) {
      stages::cell_uniforms(rows.cell[q], nu, u.data());
      INFO(name << " row " << q);
      CHECK(per_pixel[q] == law->evaluate(rows.n[q], rows.p[q], u.data()));
    }
    // By term through fixed evaluators (the last term has none): the same bits.
    std::vector<std::shared_ptr<const detail::FixedEvaluator>> fixed(terms);
    for (std::size_t t = 0; t + 1 < terms; ++t) fixed[t] = inner.fixed_evaluator(trials[t], 0.05, count);
    stages::evaluate_cells(inner, &fixed, rows, count);
    CHECK(std::memcmp(per_pixel.data(), rows.k.data(), count * sizeof(double)) == 0);
  }
}

TEST_CASE("aniso stage 4: each pixel's K is its rows' weighted counts summed in order", "[aniso][stages]") {
  stages::CellRows rows;
  rows.ensure_rows(7, 2);
  const std::size_t owner[] = {0, 0, 0, 2, 2, 3, 3};
  const double coef[] = {0.25, 0.5, 0.0, 1.0, 2.0, 0.1, 0.2}, k[] = {4, 8, 1e300, 3, 5, 10, 20};
  for (std::size_t q = 0; q < 7; ++q) {
    rows.owner[q] = owner[q];
    rows.coef[q] = coef[q];
    rows.k[q] = k[q];
  }
  std::vector<double> K(4, 0.0);
  stages::accumulate_cells(rows, 7, K.data(), "test");
  CHECK(K == std::vector<double>{0.25 * 4 + 0.5 * 8, 0.0, 3.0 + 10.0, (0.0 + 0.1 * 10) + 0.2 * 20});
  rows.k[4] = std::numeric_limits<double>::quiet_NaN();
  rows.n[4] = 12;
  rows.p[4] = 0.5;
  CHECK_THROWS_WITH(stages::accumulate_cells(rows, 7, K.data(), "where"),
                    Catch::Contains("where: the inner law returned nan at n = 12, p = 0.5"));
}

TEST_CASE("the seed followed through the counter's stages by hand is count_pixels", "[aniso][stages]") {
  const std::shared_ptr<const CountingLaw> law(make_law("gated"));
  const std::size_t w = 24, h = 16, m = w * h;
  std::vector<double> uv(2 * m), jac(4 * m), slope(2 * m);
  for (std::size_t i = 0; i < m; ++i) {
    const double x = static_cast<double>(i % w), y = static_cast<double>(i / w), depth = 1.0 + y / 4.0;
    uv[2 * i] = (x - 12.0) / 64.0 * depth;
    uv[2 * i + 1] = depth;
    jac[4 * i] = depth / 512.0;
    jac[4 * i + 1] = 1e-4 * x;
    jac[4 * i + 2] = 1e-5;
    jac[4 * i + 3] = depth * depth / 256.0;
    slope[2 * i] = 0.3 * x;
    slope[2 * i + 1] = -0.2 * y;
  }
  jac[4 * 7] = NAN;  // a non-finite footprint: K = 0
  const double p = 0.1;
  const std::uint64_t seed = 21;
  for (const std::string scheme_name : {"db23_trilinear", "zk16_aniso"}) {
    for (const CounterOptions& options : kOptions) {
      const AnisoCounter counter(scheme_named(scheme_name), InnerLaw::from_law(law), options);
      std::vector<double> K(m);
      std::vector<std::int32_t> evaluations(m);
      std::vector<std::uint8_t> status(m);
      counter.count_pixels(kDensity, {&p, 1}, uv.data(), jac.data(), slope.data(), m, seed,
                           {K.data(), evaluations.data(), status.data()});
      // By hand, one chunk of all pixels.
      stages::CellRows rows;
      stages::TermCells cells(options, counter.scheme().max_terms());
      std::vector<Term> terms;
      std::vector<double> by_hand(m, 0.0);
      std::size_t gathered = 0;
      for (std::size_t i = 0; i < m; ++i) {
        const Shape shape = shape_from_jacobian(jac[4 * i], jac[4 * i + 1], jac[4 * i + 2], jac[4 * i + 3]);
        const stages::Pixel px{
            uv[2 * i], uv[2 * i + 1], slope[2 * i], slope[2 * i + 1], p, seed, stages::image_select_seed(seed)};
        ShapeStatus st;
        if (!stages::footprint_terms(counter.scheme(), kDensity, shape, nullptr, terms, st)) continue;
        rows.ensure_rows(gathered + terms.size() * 16, 2);
        for (std::size_t ti = 0; ti < terms.size(); ++ti)
          gathered += cells.gather(px, i, ti, terms[ti], rows, gathered);
      }
      stages::evaluate_cells(counter.inner(), nullptr, rows, gathered);
      stages::accumulate_cells(rows, gathered, by_hand.data(), "test");
      INFO(scheme_name << " spatial " << spatial_name(options.spatial) << " angular " << angular_name(options.angular)
                       << " " << realization_name(options.realization));
      CHECK(std::memcmp(by_hand.data(), K.data(), m * sizeof(double)) == 0);
      CHECK(status[7] == static_cast<std::uint8_t>(ShapeStatus::kNonFinite));
    }
  }
}
