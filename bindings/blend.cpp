// LOD blending (glintlab/counting/blend.hpp): a blend rule over an inner law, built-in or written in Python, on a
// ladder of levels.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/counting/blend.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

using BlendClass = py::class_<BlendedLaw, std::shared_ptr<BlendedLaw>>;

void bind_blend_sampling(BlendClass& blend) {
  blend
      .def(
          "sample",
          [](const BlendedLaw& b, double density, const Array& area, const Array& p, std::size_t count,
             std::uint64_t seed, const py::object& out_arg) {
            OutArray out = output_array(out_arg, count);
            double* o = out.mutable_data();
            {
              LongCall release;
              b.sample(density, param(area), param(p), count, seed, o);
            }
            return out;
          },
          py::arg("N"), py::arg("P"), py::arg("p"), py::arg("count"), py::arg("seed"), py::arg("out") = py::none())
      .def(
          "sample_at",
          [](const BlendedLaw& b, double density, const Array& area, const Array& p, const Array& x, const Array& y,
             std::size_t count, std::uint64_t seed, const py::object& out_arg) {
            OutArray out = output_array(out_arg, count);
            double* o = out.mutable_data();
            {
              LongCall release;
              b.sample_at(density, param(area), param(p), param(x), param(y), count, seed, o);
            }
            return out;
          },
          py::arg("N"), py::arg("P"), py::arg("p"), py::arg("x"), py::arg("y"), py::arg("count"), py::arg("seed"),
          py::arg("out") = py::none());
}

void bind_blended_law(py::module_& m) {
  BlendClass blend(m, "BlendedLaw");
  blend.def_property_readonly("name", [](const BlendedLaw& b) { return b.rule().name(); })
      .def_property_readonly("params", [](const BlendedLaw& b) { return from_params(b.rule().params()); })
      .def_property_readonly("inner_name", [](const BlendedLaw& b) { return b.inner().name; })
      .def_property_readonly("level_ratio", [](const BlendedLaw& b) { return b.ladder().ratio(); })
      .def_property_readonly("base_area", [](const BlendedLaw& b) { return b.ladder().base_area(); })
      .def_property_readonly("binning", &BlendedLaw::binning)
      .def_property_readonly("has_pmf", &BlendedLaw::has_pmf)
      // The rule's analytic Var[K] / Var[Binomial(N P, p)] for a binomial inner law (NaN: none),
      // broadcast over P.
      .def(
          "variance_ratio",
          [](const BlendedLaw& b, const Array& area) {
            return py::vectorize([&b](double a) { return b.variance_ratio(a); })(area);
          },
          py::arg("P"))
      .def(
          "bracket",
          [](const BlendedLaw& b, double area) {
            const LevelBracket br = b.ladder().bracket(area);
            py::dict d;
            d["level"] = br.lo;
            d["area_lo"] = br.area_lo;
            d["area_hi"] = br.area_hi;
            d["w_lod"] = br.w_lod;
            d["w_area"] = br.w_area;
            return d;
          },
          py::arg("P"))
      .def("pmf", &BlendedLaw::pmf, py::arg("N"), py::arg("P"), py::arg("p"),
           py::arg("max_support") = kDefaultMaxSupport, py::call_guard<LongCall>());
  bind_blend_sampling(blend);
}

void bind_blend_factories(py::module_& m) {
  m.def(
      "make_blended_law",
      [](const std::string& name, const py::dict& kwargs, std::shared_ptr<CountingLaw> inner, double ratio,
         double base_area) {
        return std::make_shared<BlendedLaw>(make_blend(name, to_params(kwargs)), InnerLaw::from_law(std::move(inner)),
                                            LevelLadder(ratio, base_area));
      },
      py::arg("name"), py::arg("params"), py::arg("inner"), py::arg("level_ratio"), py::arg("base_area"));
  // An inner law written in Python: fn(n, p, u) -> counts, called on the calling thread with the GIL.
  m.def(
      "make_blended_law_custom",
      [](const std::string& name, const py::dict& kwargs, py::function fn, int n_uniforms,
         const std::string& inner_name, double ratio, double base_area) {
        InnerLaw inner = python_inner(fn, n_uniforms, inner_name);
        return std::make_shared<BlendedLaw>(make_blend(name, to_params(kwargs)), std::move(inner),
                                            LevelLadder(ratio, base_area));
      },
      py::arg("name"), py::arg("params"), py::arg("fn"), py::arg("n_uniforms"), py::arg("inner_name"),
      py::arg("level_ratio"), py::arg("base_area"));
  m.def("blend_infos", [] {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& info : registered_blends()) out.emplace_back(info.name, info.summary);
    return out;
  });
  m.def("roulette_moments", &blend_detail::roulette_moments, py::arg("weight"), py::arg("epsilon"));
}

}  // namespace

void bind_blends(py::module_& m) {
  bind_blended_law(m);
  bind_blend_factories(m);
}

}  // namespace glintlab::bindings
