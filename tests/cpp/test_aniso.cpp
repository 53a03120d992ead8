// Anisotropic grid schemes in the core (the Python tests cover the statistics).
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include "glintlab/counting/aniso.hpp"

using namespace glintlab;
using namespace glintlab::aniso;

TEST_CASE("footprint shapes from Jacobians report bad input instead of throwing", "[aniso]") {
  const Shape ok = shape_from_jacobian(0.04, 0.0, 0.0, 0.01);
  CHECK(ok.status == ShapeStatus::kOk);
  CHECK(ok.area == Approx(4e-4));
  CHECK(ok.ratio == Approx(4.0));
  CHECK(shape_from_jacobian(0, 0, 0, 0).status == ShapeStatus::kDegenerate);
  CHECK(shape_from_jacobian(1, 1, 1, 1).status == ShapeStatus::kDegenerate);
  CHECK(shape_from_jacobian(NAN, 0, 0, 1).status == ShapeStatus::kNonFinite);
  CHECK(shape_from_jacobian(INFINITY, 0, 0, 1).status == ShapeStatus::kNonFinite);
  CHECK_THROWS_WITH(shape_from_params(-1, 2, 0), Catch::Contains("P = -1"));
  CHECK_THROWS_WITH(shape_from_params(1e-3, 0.5, 0), Catch::Contains("r = 0.5"));
}

TEST_CASE("every grid scheme's weights are a non-negative partition of unity", "[aniso]") {
  for (const auto& info : registered_grid_schemes()) {
    const auto scheme = make_grid_scheme(info.name, {{"base_area", 1.0 / 4096}});
    for (double r : {1.0, 1.01, 1.999, 2.0, 3.3, 7.9, 8.0, 63.0, 1e5})
      for (double phi : {0.0, 0.1, 0.7853981633974483, 1.5, 3.14})
        for (double n : {0.3, 1.0, 17.0, 4000.0}) {
          std::vector<Term> terms;
          scheme->terms(shape_from_params(n / 4096, r, phi), 4096, terms);
          REQUIRE(terms.size() <= scheme->max_terms());
          double total = 0;
          for (const Term& t : terms) {
            CHECK(t.weight >= 0);
            total += t.weight;
          }
          // ZK16's probes each carry a pair of level weights summing to 1.
          const double probes = info.name == "zk16_aniso" ? static_cast<double>(terms.size()) / 2 : 1.0;
          CHECK(total == Approx(probes).epsilon(1e-12));
        }
  }
}

TEST_CASE("unknown grid schemes and parameters are refused by name", "[aniso]") {
  CHECK_THROWS_WITH(make_grid_scheme("db99"), Catch::Contains("unknown grid scheme 'db99'"));
  CHECK_THROWS_WITH(make_grid_scheme("db23_trilinear", {{"orientation_step", 50.0}}),
                    Catch::Contains("orientation_step = 50"));
  CHECK_THROWS_WITH(spatial_from_name("hex"), Catch::Contains("unknown spatial 'hex'; known: none, square, simplex"));
}
