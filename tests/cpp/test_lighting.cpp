// Glints under extended lights (glintlab/lighting/lighting.hpp): the lights' geometry, the cubature against
// closed forms, the facet truth's mean count.
#include <catch2/catch.hpp>
#include <cmath>
#include <ctime>
#include <numbers>
#include <vector>

#include "../../core/src/lighting/lighting_cubature.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "glintlab/lighting/lobes.hpp"

using namespace glintlab::lighting;

namespace {
constexpr double kPi = std::numbers::pi;

// The closed form of p for the view at the normal and a cap of half-angle a about the normal: the
// facets within a/2 of the normal (wi = reflect(n, m) is at twice m's polar angle), whose share of
// D(m)(m.n) is 1 - exp(-tan^2(a/2) / alpha^2) (Beckmann) or t / (t + alpha^2), t = tan^2(a/2) (GGX).
double cap_at_normal(Target target, double alpha, double a) {
  const double t = std::tan(0.5 * a) * std::tan(0.5 * a);
  return target == Target::kBeckmann ? -std::expm1(-t / (alpha * alpha)) : t / (t + alpha * alpha);
}
}  // namespace

TEST_CASE("the adaptive Gauss-Kronrod rule is exact on polynomials and converges on a peak", "[lighting]") {
  auto poly = [](double x, double* v) { v[0] = std::pow(x, 20); };
  const auto r = detail::adaptive_gk(poly, 1, {0.0, 1.0}, 1e-14, {0.0}, 10000);
  CHECK(r.value[0] == Approx(1.0 / 21).epsilon(1e-14));
  // A peak of width 1e-3 at 0.3, found through the geometric breakpoints.
  auto peak = [](double x, double* v) { v[0] = std::exp(-std::pow((x - 0.3) / 1e-3, 2)); };
  const auto q = detail::adaptive_gk(peak, 1, detail::geometric_points(0.0, 1.0, 0.3, 1e-3), 1e-10, {0.0}, 100000);
  CHECK(q.value[0] == Approx(std::sqrt(kPi) * 1e-3).epsilon(1e-9));
}

TEST_CASE("solid angles: cap, rectangle and disk against closed forms and cubature", "[lighting]") {
  const auto cap = Light::cap({0.2, 0.1, 1.0}, 0.3);
  CHECK(cap.solid_angle() == Approx(2 * kPi * (1 - std::cos(0.3))).epsilon(1e-14));
  CHECK(visible_solid_angle(cap).value == Approx(cap.solid_angle()).epsilon(1e-9));
  // A square of side 2 at distance 1 facing the origin: 4 asin(1/3) (= 2pi/3 for the cube's face).
  const auto square = Light::rect({0.0, 0.0, 1.0}, {2.0, 0.0, 0.0}, {0.0, 2.0, 0.0});
  CHECK(square.solid_angle() == Approx(2 * kPi / 3).epsilon(1e-12));
  const auto tilted = Light::rect({0.3, -0.2, 1.5}, {0.8, 0.1, 0.2}, {-0.1, 0.5, 0.1});
  CHECK(visible_solid_angle(tilted).value == Approx(tilted.solid_angle()).epsilon(1e-9));
  // A disk of radius r at distance d facing the origin: 2 pi (1 - d / sqrt(d^2 + r^2)).
  const auto disk = Light::disk({0.0, 0.0, 2.0}, {0.0, 0.0, 1.0}, 0.5);
  CHECK(disk.solid_angle() == Approx(2 * kPi * (1 - 2.0 / std::sqrt(4.25))).epsilon(1e-9));
  CHECK(disk.contains({0.0, 0.0, 1.0}));
  CHECK_FALSE(disk.contains({0.0, 0.0, -1.0}));  // the cone's other nappe is not the light
}

TEST_CASE("p of a cap about the normal seen from the normal equals its closed form", "[lighting]") {
  for (Target t : {Target::kBeckmann, Target::kGgx})
    for (double alpha : {0.02, 0.1, 0.5, 1.5})
      for (double a : {0.01, 0.2, 1.0, kPi / 2}) {
        const auto r = reflection_probability(t, alpha, {0.0, 0.0, 1.0}, Light::cap({0.0, 0.0, 1.0}, a), 1e-8);
        INFO("alpha " << alpha << " a " << a);
        CHECK(r.converged);
        CHECK(r.value == Approx(cap_at_normal(t, alpha, a)).epsilon(1e-7).margin(1e-300));
      }
}

TEST_CASE("p is the same for a light described as a cap and as the disk that subtends it", "[lighting]") {
  // A disk of radius tan(a) at unit distance facing the origin subtends exactly the cap of half-angle a.
  const Vec3 c{0.3, -0.2, 0.8};
  const double len = std::sqrt(0.09 + 0.04 + 0.64), a = 0.15;
  const Vec3 u{c.x / len, c.y / len, c.z / len};
  const auto disk = Light::disk(u, u, std::tan(a));
  const auto cap = Light::cap(u, a);
  for (Vec3 wo : {Vec3{0.0, 0.0, 1.0}, Vec3{-0.4, 0.2, 0.7}, Vec3{0.6, 0.1, 0.3}}) {
    const auto pd = reflection_probability(Target::kGgx, 0.1, wo, disk, 1e-8);
    const auto pc = reflection_probability(Target::kGgx, 0.1, wo, cap, 1e-8);
    CHECK(pd.value == Approx(pc.value).epsilon(1e-7));
  }
}

TEST_CASE("a light seen in a tangent frame is the light built from its rotated description", "[lighting]") {
  // A frame tilted about x by 0.7 and then about z by 0.4 (rows t, b, n in world coordinates).
  const double a = 0.7, b = 0.4;
  const Vec3 t{std::cos(b), std::sin(b), 0.0};
  const Vec3 bt{-std::sin(b) * std::cos(a), std::cos(b) * std::cos(a), std::sin(a)};
  const Vec3 n{std::sin(b) * std::sin(a), -std::cos(b) * std::sin(a), std::cos(a)};
  const Frame f{t, bt, n};
  const Vec3 c{0.3, -0.6, 1.2}, nd{0.1, -0.3, 1.0}, u{0.4, 0.1, 0.0}, v{0.0, 0.3, 0.15};
  const auto disk = Light::disk(c, nd, 0.3), rect = Light::rect(c, u, v);
  const auto disk_local = Light::disk(f.to_local(c), f.to_local(nd), 0.3);
  const auto rect_local = Light::rect(f.to_local(c), f.to_local(u), f.to_local(v));
  const Vec3 wo{-0.2, 0.3, 0.9};
  CHECK(reflection_probability(Target::kGgx, 0.3, wo, disk.in_frame(f), 1e-8).value ==
        Approx(reflection_probability(Target::kGgx, 0.3, wo, disk_local, 1e-8).value).epsilon(1e-7));
  CHECK(reflection_probability(Target::kBeckmann, 0.3, wo, rect.in_frame(f), 1e-8).value ==
        Approx(reflection_probability(Target::kBeckmann, 0.3, wo, rect_local, 1e-8).value).epsilon(1e-7));
  // Membership: a world direction is in the light when its local coordinates are in the rotated light.
  int inside = 0;
  for (int i = 0; i < 400; ++i) {
    const double th = 0.5 * (i % 20) / 20.0, ph = 2 * kPi * (i / 20) / 20.0;
    const Vec3 d{c.x / 1.371 + th * std::cos(ph), c.y / 1.371 + th * std::sin(ph), c.z / 1.371};
    const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    const Vec3 w{d.x / len, d.y / len, d.z / len};
    inside += disk.contains(w);
    CHECK(disk.in_frame(f).contains(f.to_local(w)) == disk.contains(w));
    CHECK(rect.in_frame(f).contains(f.to_local(w)) == rect.contains(w));
  }
  CHECK(inside > 10);
  CHECK(inside < 390);
  // Frames are checked orthonormal.
  CHECK_THROWS_AS(frames_from("test", "frames", {1, 0, 0, 0, 1, 0, 0, 0, 2}, 1), std::invalid_argument);
  CHECK(frames_from("test", "frames", {}, 3).empty());
}

// CPU time, not wall time: the test machines are shared, and the goal is the work per call.
// A timing, not a test of correctness: hidden from ctest (timings belong in make bench: a loaded machine or a
// sanitizer build slows it several times); run it with `build/tests/glintlab_tests "[.lighting_speed]"`.
TEST_CASE("the exact p takes under 1 ms of CPU per (view, light) at 1e-6", "[.lighting_speed]") {
  const auto rect = Light::rect({0.2, 0.1, 1.0}, {0.5, 0.0, 0.0}, {0.0, 0.3, 0.1});
  const auto cap = Light::cap({-0.3, 0.2, 1.0}, 0.05);
  const std::clock_t t0 = std::clock();
  int calls = 0;
  for (double alpha : {0.05, 0.2, 0.6})
    for (double x : {-0.5, 0.0, 0.4}) {
      reflection_probability(Target::kBeckmann, alpha, {x, 0.1, 1.0}, rect);
      reflection_probability(Target::kGgx, alpha, {x, 0.1, 1.0}, cap);
      calls += 2;
    }
  const double ms = 1e3 * double(std::clock() - t0) / CLOCKS_PER_SEC / calls;
  INFO("ms per call " << ms);
  CHECK(ms < 1.0);
}

TEST_CASE("bad lights and views are refused by name", "[lighting]") {
  CHECK_THROWS_WITH(Light::cap({0, 0, 1}, 2.0), Catch::Contains("half_angle"));
  CHECK_THROWS_WITH(Light::cap({0, 0, 0}, 0.1), Catch::Contains("direction"));
  CHECK_THROWS_WITH(Light::rect({0, 0, 1}, {1, 0, 0}, {2, 0, 0}), Catch::Contains("edge_u x edge_v"));
  CHECK_THROWS_WITH(Light::disk({0, 0, 1}, {0, 0, 1}, -1.0), Catch::Contains("radius"));
  CHECK_THROWS_WITH(reflection_probability(Target::kGgx, 0.1, {0, 0, -1}, Light::cap({0, 0, 1}, 0.1)),
                    Catch::Contains("wo[2]"));
}

TEST_CASE("the lobes' light rule integrates each light's solid angle and leaves overlaps to the first light",
          "[lighting]") {
  const auto cap = Light::cap({0.2, 0.1, 1.0}, 0.3);
  const auto tilted = Light::rect({0.3, -0.2, 1.5}, {0.8, 0.1, 0.2}, {-0.1, 0.5, 0.1});
  const auto disk = Light::disk({0.0, 0.0, 2.0}, {0.0, 0.0, 1.0}, 0.5);
  for (const auto& light : {cap, tilted, disk}) {
    const auto nodes = light_nodes(LightHit({light}, {1.0}), {8, 12});
    double total = 0.0;
    for (double w : nodes.weight) total += w;
    // A rectangle: 6 Gauss-Legendre sectors between corners, 2e-5; equal sectors would miss by 0.6 %.
    CHECK(total == Approx(light.solid_angle()).epsilon(light.corners().empty() ? 1e-8 : 5e-5));
  }
  // Two overlapping caps: the second one's nodes leave out the first's directions.
  const auto second = Light::cap({0.3, 0.1, 1.0}, 0.3);
  const auto nodes = light_nodes(LightHit({cap, second}, {1.0, 1.0}), {64, 96});
  double share = 0.0;
  for (int n = nodes.first[1]; n < nodes.last[1]; ++n) share += nodes.weight[n];
  CHECK(share < 0.5 * second.solid_angle());
  CHECK(share > 0.0);
  LobeRule bad{0, 12};
  CHECK_THROWS_WITH(bad.check(), Catch::Contains("rings"));
}
