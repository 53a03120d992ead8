// Glints under extended lights (glintlab/lighting/lighting.hpp): lights, the exact reflection probability by
// cubature, the per-region probabilities of an environment map and the facet truth under both.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "glintlab/lighting/lobes.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

using lighting::Light;
using lighting::Vec3;

Vec3 vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

py::tuple integral(const lighting::Integral& r) { return py::make_tuple(r.value, r.error, r.evaluations, r.converged); }

void bind_light(py::module_& m) {
  py::class_<Light>(m, "Light")
      .def_static(
          "cap", [](std::array<double, 3> d, double a) { return Light::cap(vec(d), a); }, py::arg("direction"),
          py::arg("half_angle"))
      .def_static(
          "rect",
          [](std::array<double, 3> c, std::array<double, 3> u, std::array<double, 3> v) {
            return Light::rect(vec(c), vec(u), vec(v));
          },
          py::arg("center"), py::arg("edge_u"), py::arg("edge_v"))
      .def_static(
          "disk",
          [](std::array<double, 3> c, std::array<double, 3> n, double r) { return Light::disk(vec(c), vec(n), r); },
          py::arg("center"), py::arg("normal"), py::arg("radius"))
      .def_property_readonly("center",
                             [](const Light& l) {
                               return std::array<double, 3>{l.center().x, l.center().y, l.center().z};
                             })
      .def_property_readonly("solid_angle", &Light::solid_angle)
      .def(
          "contains",
          [](const Light& l, py::array_t<double, py::array::c_style | py::array::forcecast> w) {
            const auto n = w.size() / 3;
            py::array_t<bool> out(static_cast<py::ssize_t>(n));
            const double* d = w.data();
            for (py::ssize_t i = 0; i < static_cast<py::ssize_t>(n); ++i)
              out.mutable_data()[i] = l.contains({d[3 * i], d[3 * i + 1], d[3 * i + 2]});
            return out;
          },
          py::arg("w"))
      .def("__repr__", &Light::describe);
}

void bind_probabilities(py::module_& m) {
  m.def(
      "reflection_probability",
      [](const std::string& target, double alpha, std::array<double, 3> wo, const Light& light, double rel_tol,
         std::int64_t max_evaluations) {
        const auto t = lighting::parse_target(target);
        lighting::Integral r;
        {
          LongCall release;
          r = lighting::reflection_probability(t, alpha, vec(wo), light, rel_tol, max_evaluations);
        }
        return integral(r);
      },
      py::arg("target"), py::arg("alpha"), py::arg("wo"), py::arg("light"), py::arg("rel_tol") = 1e-6,
      py::arg("max_evaluations") = 4000000);
  m.def(
      "reflection_probabilities",
      [](const std::string& target, double alpha, const std::vector<double>& wo, const Light& light, double rel_tol,
         const std::vector<double>& frames) {
        const auto t = lighting::parse_target(target);
        const auto fr = lighting::frames_from("reflection_probabilities", "frames", frames, wo.size() / 3);
        std::pair<std::vector<double>, std::vector<double>> r;
        {
          LongCall release;
          r = lighting::reflection_probabilities(t, alpha, wo, light, rel_tol, fr);
        }
        return py::make_tuple(to_numpy(r.first), to_numpy(r.second));
      },
      py::arg("target"), py::arg("alpha"), py::arg("wo"), py::arg("light"), py::arg("rel_tol") = 1e-6,
      py::arg("frames") = std::vector<double>{});
  m.def(
      "half_vector_solid_angle",
      [](std::array<double, 3> wo, const Light& light, double rel_tol) {
        return integral(lighting::half_vector_solid_angle(vec(wo), light, rel_tol));
      },
      py::arg("wo"), py::arg("light"), py::arg("rel_tol") = 1e-8);
  m.def(
      "visible_solid_angle",
      [](const Light& light, double rel_tol) { return integral(lighting::visible_solid_angle(light, rel_tol)); },
      py::arg("light"), py::arg("rel_tol") = 1e-10);
}

lighting::RegionMap region_map(int rows, int cols, int regions, const std::vector<int>& labels,
                               const std::vector<double>& radiance) {
  lighting::RegionMap map{rows, cols, regions, labels, radiance};
  lighting::check_region_map(map);
  return map;
}

std::vector<spatial::Placed> placed(const std::vector<spatial::Footprint>& fps,
                                    const std::vector<std::pair<double, double>>& centers) {
  if (centers.size() != fps.size())
    throw_invalid_message("facet_truth: " + std::to_string(fps.size()) + " footprints but " +
                          std::to_string(centers.size()) + " centers; expected one center per footprint");
  std::vector<spatial::Placed> out;
  for (std::size_t i = 0; i < fps.size(); ++i) out.push_back({fps[i], centers[i].first, centers[i].second});
  return out;
}

py::tuple truth_tuple(const lighting::FacetTruth& t, std::size_t count, std::size_t channels) {
  auto counts = to_numpy(t.counts).reshape({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(channels)});
  return py::make_tuple(counts, to_numpy(t.radiance), to_numpy(t.facets));
}

void bind_regions(py::module_& m) {
  m.def(
      "region_probabilities",
      [](const std::string& target, double alpha, std::array<double, 3> wo, int rows, int cols, int regions,
         const std::vector<int>& labels, const std::vector<double>& radiance, double rel_tol) {
        const auto t = lighting::parse_target(target);
        const auto map = region_map(rows, cols, regions, labels, radiance);
        std::vector<lighting::Integral> r;
        {
          LongCall release;
          r = lighting::region_probabilities(t, alpha, vec(wo), map, rel_tol);
        }
        py::list out;
        for (const auto& x : r) out.append(integral(x));
        return out;
      },
      py::arg("target"), py::arg("alpha"), py::arg("wo"), py::arg("rows"), py::arg("cols"), py::arg("regions"),
      py::arg("labels"), py::arg("radiance"), py::arg("rel_tol") = 1e-6);
  m.def(
      "region_probabilities_many",
      [](const std::string& target, double alpha, const std::vector<double>& wo, int rows, int cols, int regions,
         const std::vector<int>& labels, const std::vector<double>& radiance, double rel_tol,
         const std::vector<double>& frames) {
        const auto t = lighting::parse_target(target);
        const auto map = region_map(rows, cols, regions, labels, radiance);
        const auto fr = lighting::frames_from("region_probabilities", "frames", frames, wo.size() / 3);
        std::pair<std::vector<double>, std::vector<double>> r;
        {
          LongCall release;
          r = lighting::region_probabilities_many(t, alpha, wo, map, rel_tol, fr);
        }
        const py::ssize_t count = static_cast<py::ssize_t>(wo.size() / 3), k = regions;
        return py::make_tuple(to_numpy(r.first).reshape({count, k}), to_numpy(r.second).reshape({count, k}));
      },
      py::arg("target"), py::arg("alpha"), py::arg("wo"), py::arg("rows"), py::arg("cols"), py::arg("regions"),
      py::arg("labels"), py::arg("radiance"), py::arg("rel_tol") = 1e-6, py::arg("frames") = std::vector<double>{});
}

void bind_facets(py::module_& m) {
  // The one "mirror direction hits the light" test, handed to the methods' own truths (KPT25, WWH18).
  py::class_<lighting::LightHit>(m, "LightHit")
      .def(py::init<std::vector<Light>, std::vector<double>>(), py::arg("lights"), py::arg("radiance"))
      .def(py::init([](int rows, int cols, int regions, const std::vector<int>& labels,
                       const std::vector<double>& radiance) {
             return lighting::LightHit(region_map(rows, cols, regions, labels, radiance));
           }),
           py::arg("rows"), py::arg("cols"), py::arg("regions"), py::arg("labels"), py::arg("radiance"))
      .def_property_readonly("channels", &lighting::LightHit::channels);
  m.def(
      "facet_truth_lights",
      [](const std::string& target, double alpha, std::int64_t side, const std::vector<spatial::Footprint>& fps,
         const std::vector<std::pair<double, double>>& centers, const std::vector<double>& wo,
         const std::vector<Light>& lights, const std::vector<double>& radiance, std::uint64_t seed,
         const std::vector<double>& frames) {
        const auto t = lighting::parse_target(target);
        const auto pl = placed(fps, centers);
        const auto fr = lighting::frames_from("facet_truth_lights", "frames", frames, fps.size());
        lighting::FacetTruth r;
        {
          LongCall release;
          r = lighting::facet_truth_lights(t, alpha, side, pl, wo, lights, radiance, seed, fr);
        }
        return truth_tuple(r, fps.size(), lights.size());
      },
      py::arg("target"), py::arg("alpha"), py::arg("side"), py::arg("footprints"), py::arg("centers"), py::arg("wo"),
      py::arg("lights"), py::arg("radiance"), py::arg("seed"), py::arg("frames") = std::vector<double>{});
  m.def(
      "facet_truth_map",
      [](const std::string& target, double alpha, std::int64_t side, const std::vector<spatial::Footprint>& fps,
         const std::vector<std::pair<double, double>>& centers, const std::vector<double>& wo, int rows, int cols,
         int regions, const std::vector<int>& labels, const std::vector<double>& radiance, std::uint64_t seed,
         const std::vector<double>& frames) {
        const auto t = lighting::parse_target(target);
        const auto map = region_map(rows, cols, regions, labels, radiance);
        const auto pl = placed(fps, centers);
        const auto fr = lighting::frames_from("facet_truth_map", "frames", frames, fps.size());
        lighting::FacetTruth r;
        {
          LongCall release;
          r = lighting::facet_truth_map(t, alpha, side, pl, wo, map, seed, fr);
        }
        return truth_tuple(r, fps.size(), std::size_t(regions));
      },
      py::arg("target"), py::arg("alpha"), py::arg("side"), py::arg("footprints"), py::arg("centers"), py::arg("wo"),
      py::arg("rows"), py::arg("cols"), py::arg("regions"), py::arg("labels"), py::arg("radiance"), py::arg("seed"),
      py::arg("frames") = std::vector<double>{});
}

// The lobes of the methods' own truths (lobes.hpp).
void bind_lobes(py::module_& m) {
  // How the methods' own truths light their glints (lobes.hpp): "lobe" or "normal", the product rules'
  // nodes, and the wrong variants (mirror false, unnormalised true).
  py::class_<lighting::GlintLightOptions>(m, "GlintLightOptions")
      .def(py::init([](const std::string& lit_as, int rings, int sectors, bool mirror, bool unnormalised) {
             if (lit_as != "lobe" && lit_as != "normal")
               throw_invalid("light truth", "lit_as", lit_as, "\"lobe\" or \"normal\"");
             lighting::GlintLightOptions o;
             o.lit_as = lit_as == "lobe" ? lighting::GlintLight::kLobe : lighting::GlintLight::kNormal;
             o.rule = {rings, sectors};
             o.rule.check();
             o.mirror = mirror;
             o.unnormalised = unnormalised;
             return o;
           }),
           py::arg("lit_as"), py::arg("rings"), py::arg("sectors"), py::arg("mirror"), py::arg("unnormalised"));
  m.def(
      "light_nodes",
      [](const lighting::LightHit& hit, int rings, int sectors) {
        const auto nodes = lighting::light_nodes(hit, {rings, sectors});
        py::array_t<double> dirs({static_cast<py::ssize_t>(nodes.dir.size()), py::ssize_t{3}});
        double* d = dirs.mutable_data();
        for (std::size_t k = 0; k < nodes.dir.size(); ++k) {
          d[3 * k] = nodes.dir[k].x;
          d[3 * k + 1] = nodes.dir[k].y;
          d[3 * k + 2] = nodes.dir[k].z;
        }
        return py::make_tuple(dirs, to_numpy(nodes.weight), nodes.first, nodes.last, to_numpy(nodes.radius));
      },
      py::arg("hit"), py::arg("rings"), py::arg("sectors"));
}

}  // namespace

void bind_lighting(py::module_& m) {
  bind_light(m);
  bind_probabilities(m);
  bind_regions(m);
  bind_facets(m);
  bind_lobes(m);
}

}  // namespace glintlab::bindings
