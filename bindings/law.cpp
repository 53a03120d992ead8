// Counting laws (glintlab/counting/law.hpp): the law object (CoreLaw), the registry with each law's traits, the
// batch uniforms and the drivers' thread count and SIMD level.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/uniform_rows.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

// A law's declared traits (law.hpp LawTraits) as plain Python values, so that the Python side can
// derive its law lists (studies, benchmarks, bounds, checks) from the registry.
py::list bounds_list(const LawTraits& t) {
  py::list bounds;
  for (const auto& b : t.bounds) {
    py::dict regime;  // insertion order = declaration order (it names the bound)
    for (const auto& [key, range] : b.regime) regime[py::str(key)] = py::make_tuple(range[0], range[1]);
    py::dict d;
    d["params"] = from_params(b.params);
    d["regime"] = regime;
    d["metrics"] = b.metrics;
    d["reason"] = b.reason;
    bounds.append(d);
  }
  return bounds;
}

py::dict traits_dict(const LawInfo& info) {
  const LawTraits& t = info.traits;
  const auto variants = [](const std::vector<LawParams>& list) {
    py::list out;
    for (const auto& params : list) out.append(from_params(params));
    return out;
  };
  py::list cost_points;
  for (const auto& [n, p] : t.cost_points) cost_points.append(py::make_tuple(n, p));
  py::dict d;
  d["name"] = info.name;
  d["summary"] = info.summary;
  d["declared"] = t.declared();
  d["output"] = law_output_name(t.output);
  d["support"] = support_bound_name(t.support);
  d["support_note"] = t.support_note;
  d["constant_time"] = t.constant_time;
  d["reference"] = t.reference;
  d["regime"] = t.regime;
  d["cost"] = t.cost;
  d["study_variants"] = variants(t.study_variants);
  d["bench_variants"] = variants(t.bench_variants);
  d["test_variants"] = variants(t.test_variants);
  d["cost_points"] = cost_points;
  d["bounds"] = bounds_list(t);
  py::dict domain;
  domain["max_n"] = t.domain.max_n;
  domain["note"] = t.domain.note;
  d["domain"] = domain;
  d["shader"] = t.shader;
  return d;
}

// CoreLaw's batch methods: sample and evaluate over numpy arrays, without the GIL.
template <class Class>
void bind_law_batches(Class& law_class) {
  law_class
      .def(
          "sample",
          [](const CountingLaw& law, const Array& n, const Array& p, std::size_t count, std::uint64_t s,
             const std::string& precision, const py::object& out_arg) {
            const Precision prec = precision_from_name(precision);
            OutArray out = output_array(out_arg, count);
            double* o = out.mutable_data();
            {
              LongCall release;
              sample_many(law, param(n), param(p), count, s, o, prec);
            }
            return out;
          },
          py::arg("n"), py::arg("p"), py::arg("count"), py::arg("seed"), py::arg("precision"),
          py::arg("out") = py::none())
      .def(
          "evaluate",
          [](const CountingLaw& law, const Array& n, const Array& p, const Array& u, const std::string& precision) {
            const Precision prec = precision_from_name(precision);
            const auto count = static_cast<std::size_t>(u.ndim() == 2 ? u.shape(0) : 0);
            if (u.ndim() != 2 || u.shape(1) != law.n_uniforms())
              glintlab::throw_invalid_message(law.name() + ".evaluate: u must have shape (m, " +
                                              std::to_string(law.n_uniforms()) + ")");
            py::array_t<double> out(static_cast<py::ssize_t>(count));
            double* o = out.mutable_data();
            {
              LongCall release;
              evaluate_many(law, param(n), param(p), u.data(), count, o, prec);
            }
            return out;
          },
          py::arg("n"), py::arg("p"), py::arg("u"), py::arg("precision"));
}

void bind_core_law(py::module_& m) {
  py::class_<CountingLaw, std::shared_ptr<CountingLaw>> law_class(m, "CoreLaw");
  law_class.def_property_readonly("name", &CountingLaw::name)
      .def_property_readonly("n_uniforms", &CountingLaw::n_uniforms)
      .def_property_readonly("has_pmf", &CountingLaw::has_pmf)
      .def_property_readonly("binning", &CountingLaw::binning)
      .def_property_readonly("params", [](const CountingLaw& law) { return from_params(law.params()); })
      .def(
          "pmf",
          [](const CountingLaw& law, double n, double p, std::size_t max_support) {
            law.validate(n, p, 0, false);
            LongCall release;
            return law.pmf(n, p, max_support);
          },
          py::arg("n"), py::arg("p"), py::arg("max_support") = kDefaultMaxSupport)
      .def(
          "supports",
          [](const CountingLaw& law, const std::string& precision) {
            return law.supports(precision_from_name(precision));
          },
          py::arg("precision"));
  bind_law_batches(law_class);
  // The law's cost model (CountingLaw::work_units), broadcast over n and p like numpy. A few
  // flops per element: not worth releasing the GIL for.
  law_class.def(
      "work_units",
      [](const CountingLaw& law, const Array& n, const Array& p) {
        return py::vectorize([&law](double nn, double pp) {
          if (!law.accepts(nn, pp)) law.validate(nn, pp, 0, false);
          return law.work_units(nn, pp);
        })(n, p);
      },
      py::arg("n"), py::arg("p"));
}

void bind_law_registry(py::module_& m) {
  m.def(
      "law_traits", [](const std::string& name) { return traits_dict(law_registry().find(name)); }, py::arg("name"));
  m.def("all_law_traits", [] {
    py::dict out;  // sorted by name, as the registry
    for (const auto& info : registered_laws()) out[py::str(info.name)] = traits_dict(info);
    return out;
  });
  m.def(
      "make_law",
      [](const std::string& name, const py::dict& kwargs) {
        return std::shared_ptr<CountingLaw>(make_law(name, to_params(kwargs)));
      },
      py::arg("name"), py::arg("params"));
  m.def("law_infos", [] {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& info : registered_laws()) out.emplace_back(info.name, info.summary);
    return out;
  });
}

}  // namespace

void bind_laws(py::module_& m) {
  bind_core_law(m);
  bind_law_registry(m);
}

void bind_uniforms_and_threads(py::module_& m) {
  m.def(
      "uniforms",
      [](std::size_t start, std::size_t count, int k, std::uint64_t s, int stream) {
        if (k < 0) glintlab::throw_invalid("", "n_uniforms", std::to_string(k), "an integer >= 0");
        if (stream < 0 || stream > 65535)
          glintlab::throw_invalid("", "stream", std::to_string(stream), "an integer in [0, 65535]");
        py::array_t<double> out({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(k)});
        double* o = out.mutable_data();
        {
          LongCall release;
          fill_uniforms(s, static_cast<std::uint16_t>(stream), start, count, k, o);
        }
        return out;
      },
      py::arg("start"), py::arg("count"), py::arg("k"), py::arg("seed"), py::arg("stream"));
  m.def("set_num_threads", &set_num_threads, py::arg("threads"));
  m.def("num_threads", &num_threads);
  // The SIMD level the vector kernels run at (2 AVX-512, 1 AVX2, 0 portable), for benchmark headers.
  m.def("simd_level", &detail::simd_level);
}

}  // namespace glintlab::bindings
