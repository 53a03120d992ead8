// The facet truth under extended lights and environment maps, and the exact per-region reflection
// probabilities of a map (docs/math/lighting.md#lighting-facets, #lighting-env-exact).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "lighting_cubature.hpp"

namespace glintlab::lighting {

namespace {

constexpr double kPi = std::numbers::pi;
// The facets' random numbers: cell (i, j) of the layout keyed by (seed, i, j) on a stream of its own.
constexpr std::uint16_t kStreamLightingFacets = 21;

// A normal drawn from D(m)(m.n) by inverting its CDF in tan^2(theta) (Walter et al. 2007):
// Beckmann tan^2 = -alpha^2 log(u), GGX tan^2 = alpha^2 u / (1 - u); phi uniform.
Vec3 sample_normal(Target target, double alpha, double u, double v) {
  const double a2 = alpha * alpha;
  const double tan2 = target == Target::kBeckmann ? -a2 * std::log(u) : a2 * u / (1.0 - u);
  const double c = 1.0 / std::sqrt(1.0 + tan2), s = std::sqrt(std::max(0.0, 1.0 - c * c));
  const double phi = 2 * kPi * v;
  return {s * std::cos(phi), s * std::sin(phi), c};
}

void check_common(std::string_view where, double alpha, std::int64_t side, const std::vector<spatial::Placed>& fps,
                  const std::vector<double>& wo) {
  if (!(alpha > 0) || !std::isfinite(alpha)) throw_invalid(where, "alpha", alpha, "a finite number > 0");
  if (side < 1 || side > (std::int64_t(1) << 30)) throw_invalid(where, "side", double(side), "an integer in [1, 2^30]");
  check_length(where, "wo", wo.size(), 3 * fps.size());
  for (std::size_t i = 0; i < fps.size(); ++i) {
    const auto& f = fps[i].footprint;
    if (!(2 * f.half_width() < 1 && 2 * f.half_height() < 1))
      throw_invalid(where, indexed_name("footprints", i, true), 2 * std::max(f.half_width(), f.half_height()),
                    "a footprint whose bounding box is narrower than the unit domain");
    if (!(wo[3 * i + 2] > 0) || !std::isfinite(wo[3 * i]) || !std::isfinite(wo[3 * i + 1]))
      throw_invalid(where, "wo[" + std::to_string(i) + ", 2]", wo[3 * i + 2], "a finite view above the horizon");
  }
}

// Every facet of the layout inside each footprint, counted for the channel `hit` gives it.
FacetTruth count_facets(Target target, double alpha, std::int64_t side, const std::vector<spatial::Placed>& fps,
                        const std::vector<double>& wo, const LightHit& hit, std::uint64_t seed,
                        const std::vector<Frame>& frames) {
  FacetTruth out;
  const std::size_t count = fps.size();
  if (!frames.empty()) check_length("facet_truth", "frames", frames.size(), count);
  const int channels = hit.channels();
  out.counts.assign(count * channels, 0.0);
  out.radiance.assign(count, 0.0);
  out.facets.assign(count, 0.0);
  const double m = double(side);
  glintlab::detail::parallel_chunks(count, 1, 2, [&](std::size_t i0, std::size_t i1) {
    for (std::size_t i = i0; i < i1; ++i) {
      const auto& fp = fps[i].footprint;
      const double x = fps[i].x - std::floor(fps[i].x), y = fps[i].y - std::floor(fps[i].y);
      const double n = std::sqrt(wo[3 * i] * wo[3 * i] + wo[3 * i + 1] * wo[3 * i + 1] + wo[3 * i + 2] * wo[3 * i + 2]);
      const Vec3 v{wo[3 * i] / n, wo[3 * i + 1] / n, wo[3 * i + 2] / n};
      const Frame* frame = frames.empty() ? nullptr : &frames[i];
      const auto ix0 = std::int64_t(std::floor((x - fp.half_width()) * m)),
                 ix1 = std::int64_t(std::floor((x + fp.half_width()) * m));
      const auto iy0 = std::int64_t(std::floor((y - fp.half_height()) * m)),
                 iy1 = std::int64_t(std::floor((y + fp.half_height()) * m));
      for (std::int64_t iy = iy0; iy <= iy1; ++iy)
        for (std::int64_t ix = ix0; ix <= ix1; ++ix) {
          const auto cx = std::uint32_t(((ix % side) + side) % side), cy = std::uint32_t(((iy % side) + side) % side);
          CounterRng rng(seed, cx, cy, 0, kStreamLightingFacets);
          const double px = (double(ix) + rng.uniform()) / m, py = (double(iy) + rng.uniform()) / m;
          if (!fp.contains(px - x, py - y)) continue;
          out.facets[i] += 1;
          const double u = rng.uniform(), w = rng.uniform();
          double radiance = 0;
          const int channel = hit.hit(v, sample_normal(target, alpha, u, w), radiance, true, frame);
          if (channel < 0) continue;
          out.counts[i * channels + channel] += 1;
          out.radiance[i] += radiance;
        }
    }
  });
  return out;
}

}  // namespace

int RegionMap::cell(Vec3 w) const {
  const double theta = std::acos(std::clamp(w.z, -1.0, 1.0));
  double phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * kPi;
  const int i = std::clamp(int(theta / kPi * rows), 0, rows - 1);
  const int j = std::clamp(int(phi / (2 * kPi) * cols), 0, cols - 1);
  return i * cols + j;
}

void check_region_map(const RegionMap& map) {
  if (map.rows < 2 || map.cols < 1) throw_invalid("region map", "rows", map.rows, "a grid of at least 2 x 1 cells");
  if (map.regions < 1) throw_invalid("region map", "regions", map.regions, "at least 1 region");
  const std::size_t cells = std::size_t(map.rows) * std::size_t(map.cols);
  check_length("region map", "labels", map.labels.size(), cells);
  check_length("region map", "radiance", map.radiance.size(), cells);
  for (std::size_t c = 0; c < cells; ++c) {
    if (map.labels[c] < -1 || map.labels[c] >= map.regions)
      throw_invalid("region map", indexed_name("labels", c, true), map.labels[c], "-1 or a region in [0, regions)");
    if (!(map.radiance[c] >= 0) || !std::isfinite(map.radiance[c]))
      throw_invalid("region map", indexed_name("radiance", c, true), map.radiance[c], "a finite radiance >= 0");
  }
}

LightHit::LightHit(std::vector<Light> lights, std::vector<double> radiance)
    : lights_(std::move(lights)), radiance_(std::move(radiance)), channels_(int(lights_.size())) {
  check_length("light hit", "radiance", radiance_.size(), lights_.size());
  if (lights_.empty()) throw_invalid("light hit", "lights", 0.0, "at least one light");
}

LightHit::LightHit(RegionMap map) : map_(std::move(map)), is_map_(true) {
  check_region_map(map_);
  channels_ = map_.regions;
}

int LightHit::hit(Vec3 wo, Vec3 m, double& radiance, bool mirror, const Frame* frame) const {
  const double c = wo.x * m.x + wo.y * m.y + wo.z * m.z;
  if (!(c > 0)) return -1;  // a facet turned away from the viewer reflects nothing towards it
  const Vec3 local = mirror ? Vec3{2 * c * m.x - wo.x, 2 * c * m.y - wo.y, 2 * c * m.z - wo.z} : m;
  if (!(local.z > 0)) return -1;  // hidden by the surface
  const Vec3 wi = frame ? frame->to_world(local) : local;
  if (is_map_) {
    const int cell = map_.cell(wi);
    radiance = map_.radiance[cell];
    return map_.labels[cell];
  }
  for (int k = 0; k < channels_; ++k)
    if (lights_[k].contains(wi)) {
      radiance = radiance_[k];
      return k;
    }
  return -1;
}

FacetTruth facet_truth_lights(Target target, double alpha, std::int64_t side,
                              const std::vector<spatial::Placed>& footprints, const std::vector<double>& wo,
                              const std::vector<Light>& lights, const std::vector<double>& radiance, std::uint64_t seed,
                              const std::vector<Frame>& frames) {
  check_common("facet_truth_lights", alpha, side, footprints, wo);
  check_length("facet_truth_lights", "radiance", radiance.size(), lights.size());
  return count_facets(target, alpha, side, footprints, wo, LightHit(lights, radiance), seed, frames);
}

FacetTruth facet_truth_map(Target target, double alpha, std::int64_t side,
                           const std::vector<spatial::Placed>& footprints, const std::vector<double>& wo,
                           const RegionMap& map, std::uint64_t seed, const std::vector<Frame>& frames) {
  check_common("facet_truth_map", alpha, side, footprints, wo);
  return count_facets(target, alpha, side, footprints, wo, LightHit(map), seed, frames);
}

namespace {

// The pieces of the azimuth run [a, b] of map row `theta` above the horizon of `frame` (none: the whole run;
// the map's own rows stop at its horizon): the directions w with w.n > 0, an arc of azimuths about n's.
std::vector<std::pair<double, double>> visible_pieces(double a, double b, double theta, const Frame* frame) {
  if (!frame) return {{a, b}};
  const Vec3 n = frame->n;
  const double nxy = std::hypot(n.x, n.y), st = std::sin(theta), ct = std::cos(theta);
  if (st * nxy <= std::abs(ct * n.z))
    return ct * n.z > 0 ? std::vector<std::pair<double, double>>{{a, b}} : std::vector<std::pair<double, double>>{};
  const double beta = std::acos(std::clamp(-ct * n.z / (st * nxy), -1.0, 1.0));
  const double start = std::atan2(n.y, n.x) - beta;
  std::vector<std::pair<double, double>> out;
  for (int turn = -1; turn <= 2; ++turn) {
    const double lo = std::max(a, start + 2 * kPi * turn), hi = std::min(b, start + 2 * beta + 2 * kPi * turn);
    if (hi > lo) out.push_back({lo, hi});
  }
  return out;
}

// One pass of region_probabilities at tolerance `rel` with per-region absolute floors `abs`: the map's rows
// in its own coordinates; with `frame` the view wo is in that tangent frame and each direction of the map is
// seen in it (Frame::to_local), cut at its horizon.
std::vector<Integral> region_pass(Target target, double alpha, Vec3 wo, const RegionMap& map, double rel,
                                  const std::vector<double>& abs, const Frame* frame) {
  const int dim = map.regions;
  const Vec3 mirror_local{-wo.x, -wo.y, wo.z};
  const Vec3 mirror = frame ? frame->to_world(mirror_local) : mirror_local;
  const double theta_peak = std::acos(std::clamp(mirror.z, -1.0, 1.0));
  double phi_peak = std::atan2(mirror.y, mirror.x);
  if (phi_peak < 0) phi_peak += 2 * kPi;
  const double scale = std::min(alpha, 0.25);
  auto f = [&](double theta, double phi) {
    const Vec3 m{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
    const Vec3 w = frame ? frame->to_local(m) : m;
    if (!(w.z > 0)) return 0.0;
    const Vec3 s{wo.x + w.x, wo.y + w.y, wo.z + w.z};
    const double len = std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
    const double c = s.z / len, woh = (wo.x * s.x + wo.y * s.y + wo.z * s.z) / len;
    return ndf_value(target, alpha, c) * c / (4.0 * woh) * std::sin(theta);
  };
  std::int64_t evaluations = 0;
  bool converged = true;
  auto outer = [&](double theta, double* out) {
    std::fill(out, out + dim, 0.0);
    const int row = std::clamp(int(theta / kPi * map.rows), 0, map.rows - 1);
    const double dphi = 2 * kPi / map.cols;
    const double phi_scale = scale / std::max(std::sin(theta), scale);
    for (int j0 = 0; j0 < map.cols;) {
      const int label = map.labels[row * map.cols + j0];
      int j1 = j0 + 1;
      while (j1 < map.cols && map.labels[row * map.cols + j1] == label) ++j1;
      // The run [j0, j1) of one label; phi's peak is also tried one turn either side (the run may wrap).
      for (const auto& [a, b] :
           label >= 0 ? visible_pieces(j0 * dphi, j1 * dphi, theta, frame) : std::vector<std::pair<double, double>>{}) {
        double centre = phi_peak;
        if (centre - a > kPi) centre -= 2 * kPi;
        if (a - centre > kPi) centre += 2 * kPi;
        auto g = [&](double phi, double* v) { v[0] = f(theta, phi); };
        const auto r = detail::adaptive_gk(g, 1, detail::geometric_points(a, b, centre, phi_scale), 0.1 * rel,
                                           {abs[label] / (2 * kPi)}, 200000);
        evaluations += r.evaluations;
        converged = converged && r.converged;
        out[label] += r.value[0];
      }
      j0 = j1;
    }
  };
  std::vector<double> pts = detail::geometric_points(0.0, 0.5 * kPi, theta_peak, scale);
  for (int i = 1; i < map.rows && i * kPi / map.rows < 0.5 * kPi; ++i) pts.push_back(i * kPi / map.rows);
  if (frame) {  // where the frame's horizon first cuts the rows (its circle's highest point)
    const double top = 0.5 * kPi - std::acos(std::clamp(frame->n.z, -1.0, 1.0));
    if (top > 0 && top < 0.5 * kPi) pts.push_back(top);
  }
  std::sort(pts.begin(), pts.end());
  const auto r = detail::adaptive_gk(outer, dim, pts, rel, abs, 20000);
  std::vector<Integral> result(dim);
  for (int d = 0; d < dim; ++d) {
    result[d].value = r.value[d];
    result[d].error = r.error[d];
    result[d].evaluations = evaluations;
    result[d].converged = converged && r.converged;
  }
  return result;
}

}  // namespace

std::vector<Integral> region_probabilities(Target target, double alpha, Vec3 wo, const RegionMap& map, double rel_tol,
                                           const Frame* frame) {
  check_region_map(map);
  if (!(alpha > 0) || !std::isfinite(alpha))
    throw_invalid("region_probabilities", "alpha", alpha, "a finite number > 0");
  if (!(wo.z > 0)) throw_invalid("region_probabilities", "wo[2]", wo.z, "a view above the horizon (wo_z > 0)");
  if (!(rel_tol > 0 && rel_tol < 1)) throw_invalid("region_probabilities", "rel_tol", rel_tol, "a number in (0, 1)");
  const double n = std::sqrt(wo.x * wo.x + wo.y * wo.y + wo.z * wo.z);
  wo = {wo.x / n, wo.y / n, wo.z / n};
  const auto coarse = region_pass(target, alpha, wo, map, 0.5, std::vector<double>(map.regions, 1e-20), frame);
  std::vector<double> floors(map.regions);
  for (int d = 0; d < map.regions; ++d) floors[d] = std::max(1e-20, 0.01 * rel_tol * std::abs(coarse[d].value));
  auto result = region_pass(target, alpha, wo, map, rel_tol, floors, frame);
  for (auto& r : result) r.evaluations += coarse[0].evaluations;
  return result;
}

std::pair<std::vector<double>, std::vector<double>> region_probabilities_many(Target target, double alpha,
                                                                              const std::vector<double>& wo,
                                                                              const RegionMap& map, double rel_tol,
                                                                              const std::vector<Frame>& frames) {
  check_region_map(map);
  if (wo.size() % 3 != 0) check_length("region_probabilities", "wo", wo.size(), 3 * (wo.size() / 3 + 1));
  const std::size_t count = wo.size() / 3, k = std::size_t(map.regions);
  if (!frames.empty()) check_length("region_probabilities", "frames", frames.size(), count);
  std::vector<double> values(count * k), errors(count * k);
  glintlab::detail::parallel_chunks(count, 4, 32, [&](std::size_t i0, std::size_t i1) {
    for (std::size_t i = i0; i < i1; ++i) {
      const auto r = region_probabilities(target, alpha, {wo[3 * i], wo[3 * i + 1], wo[3 * i + 2]}, map, rel_tol,
                                          frames.empty() ? nullptr : &frames[i]);
      for (std::size_t d = 0; d < k; ++d) values[i * k + d] = r[d].value, errors[i * k + d] = r[d].error;
    }
  });
  return {values, errors};
}

}  // namespace glintlab::lighting
