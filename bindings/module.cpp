// Thin pybind11 layer over glintlab::core. Broadcasting, argument checks, defaults and docstrings live
// in the Python package (glintlab/api/: checks.py broadcasts n and p, laws.py and the other api modules
// wrap these functions); this file only converts arrays, releases the GIL around long calls
// and maps C++ exceptions (std::invalid_argument -> ValueError, not_implemented -> NotImplementedError).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <csignal>
#include <cstring>
#include <exception>
#include <optional>

#include "bindings.hpp"
#include "glintlab/aniso.hpp"
#include "glintlab/binomial.hpp"
#include "glintlab/blend.hpp"
#include "glintlab/chi2.hpp"
#include "glintlab/detail/uniform_rows.hpp"
#include "glintlab/errors.hpp"
#include "glintlab/law.hpp"
#include "glintlab/metrics.hpp"
#include "glintlab/spatial.hpp"
#include "glintlab/validation/documents.hpp"
#include "glintlab/validation/plugin.hpp"

namespace py = pybind11;
using namespace glintlab;
using glintlab::bindings::LongCall;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

py::array_t<double> to_numpy(const std::vector<double>& v) {
  py::array_t<double> out(static_cast<py::ssize_t>(v.size()));
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(double));
  return out;
}

ParamArray param(const Array& a) { return {a.data(), static_cast<std::size_t>(a.size())}; }

// A sampler's output: the caller's preallocated `out` (a writeable C-contiguous float64 array of
// `count` elements; the Python layer checks its shape and names it) or a fresh array. Never a copy.
using OutArray = py::array_t<double, py::array::c_style>;
OutArray output_array(const py::object& out, std::size_t count) {
  if (out.is_none()) return OutArray(static_cast<py::ssize_t>(count));
  if (!py::isinstance<OutArray>(out))
    glintlab::throw_invalid_message("out is not a C-contiguous float64 array; expected one of " +
                                    std::to_string(count) + " elements");
  auto a = py::reinterpret_borrow<OutArray>(out);
  if (static_cast<std::size_t>(a.size()) != count)
    glintlab::throw_invalid_message("out has " + std::to_string(a.size()) + " elements; expected " +
                                    std::to_string(count));
  if (!a.writeable()) glintlab::throw_invalid_message("out is read-only; expected a writeable float64 array");
  return a;
}

LawParams to_params(const py::dict& kwargs) {
  LawParams params;
  for (auto item : kwargs) {
    const auto key = py::str(item.first).cast<std::string>();
    if (py::isinstance<py::str>(item.second)) {
      params[key] = item.second.cast<std::string>();
    } else if (py::isinstance<py::bool_>(item.second)) {
      params[key] = item.second.cast<bool>() ? 1.0 : 0.0;
    } else {
      try {
        params[key] = item.second.cast<double>();
      } catch (const py::cast_error&) {
        glintlab::throw_invalid_message("law parameter " + key + " = " + py::repr(item.second).cast<std::string>() +
                                        " is invalid; expected a number or a string");
      }
    }
  }
  return params;
}

py::dict from_params(const LawParams& params) {
  py::dict d;
  for (const auto& [k, v] : params) {
    if (const double* x = std::get_if<double>(&v))
      d[py::str(k)] = *x;
    else
      d[py::str(k)] = std::get<std::string>(v);
  }
  return d;
}

// An inner law written in Python: fn(n, p, u) -> counts, called on the calling thread with the GIL.
InnerLaw python_inner(py::function fn, int n_uniforms, const std::string& inner_name) {
  InnerLaw inner;
  inner.name = inner_name;
  inner.n_uniforms = n_uniforms;
  inner.integer_output = false;  // unknown: samples are binned, no exact pmf
  inner.thread_safe = false;
  const auto k = static_cast<py::ssize_t>(n_uniforms);
  inner.evaluate = [fn, k](const double* n, const double* p, const double* u, std::size_t rows_count, double* out) {
    py::gil_scoped_acquire acquire;
    const auto rows = static_cast<py::ssize_t>(rows_count);
    py::array_t<double> na(rows), pa(rows), ua({rows, k});
    std::memcpy(na.mutable_data(), n, rows_count * sizeof(double));
    std::memcpy(pa.mutable_data(), p, rows_count * sizeof(double));
    if (k > 0) std::memcpy(ua.mutable_data(), u, rows_count * static_cast<std::size_t>(k) * sizeof(double));
    const auto result = fn(na, pa, ua).cast<Array>();
    if (result.size() != rows)
      glintlab::throw_invalid_message("custom inner law returned " + std::to_string(result.size()) +
                                      " values; expected " + std::to_string(rows_count));
    std::memcpy(out, result.data(), rows_count * sizeof(double));
  };
  return inner;
}

// A law's declared traits (law.hpp LawTraits) as plain Python values, so that the Python side can
// derive its law lists (studies, benchmarks, bounds, checks) from the registry.
py::dict traits_dict(const LawInfo& info) {
  const LawTraits& t = info.traits;
  const auto variants = [](const std::vector<LawParams>& list) {
    py::list out;
    for (const auto& params : list) out.append(from_params(params));
    return out;
  };
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
  d["bounds"] = bounds;
  py::dict domain;
  domain["max_n"] = t.domain.max_n;
  domain["note"] = t.domain.note;
  d["domain"] = domain;
  d["shader"] = t.shader;
  return d;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "glintlab C++ core (use the glintlab package, not this module)";
  m.attr("__version__") = GLINTLAB_VERSION;
  py::register_exception<not_implemented>(m, "NotImplementedErrorCore", PyExc_NotImplementedError);
  glintlab::bindings::g_main_thread =
      py::module_::import("threading").attr("main_thread")().attr("ident").cast<unsigned long>();
  py::register_exception_translator([](std::exception_ptr error) {
    try {
      if (error) std::rethrow_exception(error);
    } catch (const interrupted&) { PyErr_SetNone(PyExc_KeyboardInterrupt); }
  });
  // A sweep's thread pool: on Ctrl-C the main thread asks the running C++ batches to stop.
  m.def("request_interrupt", &request_interrupt);
  m.def("clear_interrupt", &clear_interrupt);
  // Experiment and bounds documents (validation/documents.hpp): the normalized document as JSON text;
  // bad input raises InputError (a ValueError) "<source>: at <pointer>: expected ..., got ...".
  py::register_exception<validation::InputError>(m, "InputError", PyExc_ValueError);
  glintlab::bindings::bind_glinty_ndf(m);
  glintlab::bindings::bind_shaders(m);
  glintlab::bindings::bind_wwh18(m);
  glintlab::bindings::bind_method_shaders(m);
  glintlab::bindings::bind_sampler_test(m);
  glintlab::bindings::bind_sampler_shaders(m);
  glintlab::bindings::bind_wb16(m);
  glintlab::bindings::bind_scene_trace(m);
  m.def(
      "parse_document",
      [](const std::string& kind, std::string_view text, const std::string& source) {
        return validation::parse_document(kind, text, source).dump();
      },
      py::arg("kind"), py::arg("text"), py::arg("source"));
  m.def("schema_text", &validation::schema_text, py::arg("name"));
  bindings::bind_scene_images(m);

  py::class_<Distribution>(m, "Distribution",
                           "A distribution on a finite support: support and probs (numpy arrays), mean, var, "
                           "total_mass, cdf(x), and whether tails of mass < 1e-14 were trimmed. Pickles exactly.")
      .def(py::init([](const Array& support, const Array& probs, bool normalize) {
             if (support.ndim() != 1 || probs.ndim() != 1)
               glintlab::throw_invalid_message("Distribution: support and probs must be 1-D arrays");
             std::vector<double> s(support.data(), support.data() + support.size());
             std::vector<double> p(probs.data(), probs.data() + probs.size());
             return Distribution(std::move(s), std::move(p), normalize);
           }),
           py::arg("support"), py::arg("probs"), py::arg("normalize") = false)
      .def_property_readonly("support", [](const Distribution& d) { return to_numpy(d.support()); })
      .def_property_readonly("probs", [](const Distribution& d) { return to_numpy(d.probs()); })
      .def_property_readonly("mean", &Distribution::mean)
      .def_property_readonly("var", &Distribution::var)
      .def_property_readonly("total_mass", &Distribution::total_mass)
      .def_property_readonly("trimmed_below", &Distribution::trimmed_below)
      .def_property_readonly("trimmed_above", &Distribution::trimmed_above)
      .def("cdf", &Distribution::cdf, py::arg("x"))
      .def("__len__", &Distribution::size)
      .def("__repr__",
           [](const Distribution& d) {
             std::string s = "Distribution(" + std::to_string(d.size()) + " points";
             if (d.size() > 0)
               s += " in [" + format_value(d.support().front()) + ", " + format_value(d.support().back()) + "]";
             s += ", mean=" + format_value(d.mean()) + ", var=" + format_value(d.var());
             if (d.trimmed_below() || d.trimmed_above())
               s += std::string(", tails trimmed") + (d.trimmed_below() ? " below" : "") +
                    (d.trimmed_below() && d.trimmed_above() ? " and" : "") + (d.trimmed_above() ? " above" : "");
             return s + ")";
           })
      // Pickled as what rebuilds it exactly: support, probabilities, and which tails were trimmed.
      .def(py::pickle(
          [](const Distribution& d) {
            return py::make_tuple(to_numpy(d.support()), to_numpy(d.probs()), d.trimmed_below(), d.trimmed_above());
          },
          [](const py::tuple& t) {
            if (t.size() != 4) glintlab::throw_invalid_message("Distribution: a pickled state of 4 items was expected");
            const auto s = t[0].cast<std::vector<double>>();
            const auto p = t[1].cast<std::vector<double>>();
            return Distribution::with_trimmed_tails(s, p, t[2].cast<bool>(), t[3].cast<bool>());
          }))
      .def_static(
          "empirical",
          [](const Array& samples) {
            LongCall release;
            return Distribution::empirical(samples.data(), static_cast<std::size_t>(samples.size()));
          },
          py::arg("samples"));

  py::class_<CountingLaw, std::shared_ptr<CountingLaw>>(m, "CoreLaw")
      .def_property_readonly("name", &CountingLaw::name)
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
          py::arg("precision"))
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
          py::arg("n"), py::arg("p"), py::arg("u"), py::arg("precision"))
      // The law's cost model (CountingLaw::work_units), broadcast over n and p like numpy. A few
      // flops per element: not worth releasing the GIL for.
      .def(
          "work_units",
          [](const CountingLaw& law, const Array& n, const Array& p) {
            return py::vectorize([&law](double nn, double pp) {
              if (!law.accepts(nn, pp)) law.validate(nn, pp, 0, false);
              return law.work_units(nn, pp);
            })(n, p);
          },
          py::arg("n"), py::arg("p"));

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
  // C++ plugin laws (glintlab/plugin.h); `reserved`: names of the Python custom laws.
  m.def("load_plugin", &load_plugin, py::arg("path"), py::arg("reserved"));
  m.def("loaded_plugins", [] {
    std::vector<std::pair<std::string, std::vector<std::string>>> out;
    for (const auto& p : loaded_plugins()) out.emplace_back(p.path, p.laws);
    return out;
  });

  m.def("metric_names", &metric_names);
  m.def(
      "distance",
      [](const Distribution& a, const Distribution& b, const std::string& metric) {
        const Metric mm = metric_from_name(metric);
        LongCall release;
        return distance(a, b, mm);
      },
      py::arg("a"), py::arg("b"), py::arg("metric"));

  py::class_<Chi2Result>(m, "Chi2Result",
                         "A chi-square test's result: statistic, pvalue, dof, samples, note (why the test is "
                         "degenerate or failed outright) and the merged bins (lower, upper, observed, expected). "
                         "Unpacks as (statistic, pvalue), like scipy's.")
      .def_readonly("statistic", &Chi2Result::statistic)
      .def_readonly("dof", &Chi2Result::dof)
      .def_readonly("pvalue", &Chi2Result::pvalue)
      .def_readonly("samples", &Chi2Result::samples)
      .def_readonly("note", &Chi2Result::note)
      .def_property_readonly("lower", [](const Chi2Result& r) { return to_numpy(r.lower); })
      .def_property_readonly("upper", [](const Chi2Result& r) { return to_numpy(r.upper); })
      .def_property_readonly("observed", [](const Chi2Result& r) { return to_numpy(r.observed); })
      .def_property_readonly("expected", [](const Chi2Result& r) { return to_numpy(r.expected); })
      .def_readonly("resolution", &Chi2Result::resolution,
                    "the p-value's resolution: 0 when computed, 1 / (1 + draws) for a Monte Carlo estimate")
      .def(py::init([](double statistic, int dof, double pvalue, std::size_t samples, std::string note,
                       std::vector<double> lower, std::vector<double> upper, std::vector<double> observed,
                       std::vector<double> expected) {
             return Chi2Result{statistic,
                               dof,
                               pvalue,
                               samples,
                               std::move(lower),
                               std::move(upper),
                               std::move(observed),
                               std::move(expected),
                               std::move(note)};
           }),
           py::arg("statistic"), py::arg("dof"), py::arg("pvalue"), py::arg("samples"), py::arg("note") = "",
           py::arg("lower") = std::vector<double>{}, py::arg("upper") = std::vector<double>{},
           py::arg("observed") = std::vector<double>{}, py::arg("expected") = std::vector<double>{})
      // Unpacks like scipy's result: `statistic, pvalue = gl.chi2_test(...)`.
      .def("__len__", [](const Chi2Result&) { return 2; })
      .def("__getitem__",
           [](const Chi2Result& r, long i) {
             if (i == 0 || i == -2) return r.statistic;
             if (i == 1 || i == -1) return r.pvalue;
             throw py::index_error("Chi2Result unpacks as (statistic, pvalue); index " + std::to_string(i));
           })
      .def("__iter__", [](const Chi2Result& r) { return py::iter(py::make_tuple(r.statistic, r.pvalue)); })
      .def("__repr__",
           [](const Chi2Result& r) {
             std::string s = "Chi2Result(statistic=" + format_value(r.statistic) +
                             ", pvalue=" + format_value(r.pvalue) + ", dof=" + std::to_string(r.dof) +
                             ", samples=" + std::to_string(r.samples);
             if (!r.note.empty()) s += ", note=" + py::repr(py::str(r.note)).cast<std::string>();
             return s + ")";
           })
      .def(py::pickle(
          [](const Chi2Result& r) {
            return py::make_tuple(r.statistic, r.dof, r.pvalue, r.samples, r.lower, r.upper, r.observed, r.expected,
                                  r.note, r.resolution);
          },
          [](const py::tuple& t) {
            if (t.size() != 9 && t.size() != 10)
              glintlab::throw_invalid_message("Chi2Result: a pickled state of 9 or 10 items was expected");
            Chi2Result r;
            r.statistic = t[0].cast<double>();
            r.dof = t[1].cast<int>();
            r.pvalue = t[2].cast<double>();
            r.samples = t[3].cast<std::size_t>();
            r.lower = t[4].cast<std::vector<double>>();
            r.upper = t[5].cast<std::vector<double>>();
            r.observed = t[6].cast<std::vector<double>>();
            r.expected = t[7].cast<std::vector<double>>();
            r.note = t[8].cast<std::string>();
            if (t.size() == 10) r.resolution = t[9].cast<double>();
            return r;
          }));
  m.def(
      "chi2_test",
      [](const Array& samples, const Distribution& law, double min_expected, int fitted_params, double alpha) {
        LongCall release;
        return chi2_test(samples.data(), static_cast<std::size_t>(samples.size()), law, min_expected, fitted_params,
                         alpha);
      },
      py::arg("samples"), py::arg("law"), py::arg("min_expected"), py::arg("fitted_params"), py::arg("alpha") = 0.0);
  m.def("sidak_alpha", &sidak_alpha, py::arg("alpha"), py::arg("tests"));

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

  // Exact distribution functions, vectorized (numpy broadcasting).
  m.def("binomial_log_pmf", py::vectorize(&binomial::log_pmf), py::arg("k"), py::arg("n"), py::arg("p"));
  m.def("binomial_cdf", py::vectorize(&binomial::cdf), py::arg("k"), py::arg("n"), py::arg("p"));
  m.def("binomial_sf", py::vectorize(&binomial::sf), py::arg("k"), py::arg("n"), py::arg("p"));
  m.def("binomial_quantile", py::vectorize(&binomial::quantile), py::arg("u"), py::arg("n"), py::arg("p"));
  m.def("poisson_log_pmf", py::vectorize(&poisson::log_pmf), py::arg("k"), py::arg("lam"));
  m.def("poisson_cdf", py::vectorize(&poisson::cdf), py::arg("k"), py::arg("lam"));
  m.def("poisson_sf", py::vectorize(&poisson::sf), py::arg("k"), py::arg("lam"));
  m.def("poisson_quantile", py::vectorize(&poisson::quantile), py::arg("u"), py::arg("lam"));

  // Spatialized Bernoulli trials (ground truth).
  using spatial::Footprint;
  py::class_<Footprint>(m, "Footprint")
      .def_static("rect", &Footprint::rect, py::arg("width"), py::arg("height"), py::arg("angle") = 0.0)
      .def_static("ellipse", &Footprint::ellipse, py::arg("a"), py::arg("b"), py::arg("angle") = 0.0)
      .def_static("from_uv_derivatives", &Footprint::from_uv_derivatives, py::arg("dudx"), py::arg("dvdx"),
                  py::arg("dudy"), py::arg("dvdy"))
      .def_property_readonly("kind",
                             [](const Footprint& f) { return f.kind() == Footprint::Kind::kRect ? "rect" : "ellipse"; })
      .def_property_readonly("a", &Footprint::a)
      .def_property_readonly("b", &Footprint::b)
      .def_property_readonly("angle", &Footprint::angle)
      .def_property_readonly("area", &Footprint::area)
      .def_property_readonly("half_width", &Footprint::half_width)
      .def_property_readonly("half_height", &Footprint::half_height)
      .def("contains", py::vectorize(&Footprint::contains), py::arg("x"), py::arg("y"))
      .def("overlap", &Footprint::overlap, py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"))
      .def("__repr__", &Footprint::describe);
  py::class_<spatial::GroundTruth>(m, "GroundTruth")
      .def(py::init([](const std::string& layout, double density, const Footprint& fp, double p,
                       std::optional<std::pair<double, double>> center) {
             return spatial::GroundTruth(spatial::parse_layout(layout), density, fp, p, center);
           }),
           py::arg("layout"), py::arg("density"), py::arg("footprint"), py::arg("p"), py::arg("center") = py::none())
      .def_property_readonly("layout", [](const spatial::GroundTruth& g) { return spatial::layout_name(g.layout()); })
      .def_property_readonly("density", &spatial::GroundTruth::density)
      .def_property_readonly("p", &spatial::GroundTruth::p)
      .def_property_readonly("n", &spatial::GroundTruth::n)
      .def_property_readonly("grid_side", &spatial::GroundTruth::grid_side)
      .def_property_readonly("footprint", &spatial::GroundTruth::footprint)
      .def_property_readonly("center", &spatial::GroundTruth::center)
      .def("pmf", &spatial::GroundTruth::pmf, py::arg("max_support") = kDefaultMaxSupport, py::arg("quadrature") = 16,
           py::call_guard<glintlab::bindings::LongCall>())
      .def(
          "sample",
          [](const spatial::GroundTruth& g, std::size_t count, std::uint64_t seed) {
            std::vector<double> out;
            {
              LongCall release;
              out = g.sample(count, seed);
            }
            return to_numpy(out);
          },
          py::arg("count"), py::arg("seed"));
  m.def(
      "stratified_coverage",
      [](const Footprint& f, double x, double y, std::int64_t side) {
        const auto cov = spatial::stratified_coverage(f, x, y, side);
        return py::make_tuple(cov.interior, to_numpy(cov.fractions));
      },
      py::arg("footprint"), py::arg("x"), py::arg("y"), py::arg("side"));
  m.def(
      "joint_counts",
      [](const std::string& layout, double density, double p, const std::vector<Footprint>& fps,
         const std::vector<std::pair<double, double>>& centers, std::size_t count, std::uint64_t seed) {
        if (fps.size() != centers.size())
          glintlab::throw_invalid_message("joint_counts: " + std::to_string(fps.size()) + " footprints but " +
                                          std::to_string(centers.size()) +
                                          " centers; expected one center per footprint");
        std::vector<spatial::Placed> placed;
        for (std::size_t j = 0; j < fps.size(); ++j) placed.push_back({fps[j], centers[j].first, centers[j].second});
        const auto lay = spatial::parse_layout(layout);
        std::vector<double> out;
        {
          LongCall release;
          out = spatial::joint_counts(lay, density, p, placed, count, seed);
        }
        auto arr = to_numpy(out);
        return arr.reshape({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(fps.size())});
      },
      py::arg("layout"), py::arg("density"), py::arg("p"), py::arg("footprints"), py::arg("centers"), py::arg("count"),
      py::arg("seed"));

  // LOD blending.
  py::class_<BlendedLaw, std::shared_ptr<BlendedLaw>>(m, "BlendedLaw")
      .def_property_readonly("name", [](const BlendedLaw& b) { return b.rule().name(); })
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
           py::arg("max_support") = kDefaultMaxSupport, py::call_guard<glintlab::bindings::LongCall>())
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

  // Anisotropic grids (aniso.hpp).
  m.def("grid_scheme_infos", [] {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& info : aniso::registered_grid_schemes()) out.emplace_back(info.name, info.summary);
    return out;
  });
  m.def(
      "grid_scheme_traits",
      [](const std::string& name) {
        const auto info = aniso::grid_scheme_registry().find(name);
        py::dict d;
        d["name"] = info.name;
        d["summary"] = info.summary;
        d["native_law"] = info.traits.native_law;
        return d;
      },
      py::arg("name"));
  m.def(
      "footprint_shapes",
      [](const Array& jac) {
        // jac: (m, 4) rows (du/dx, dv/dx, du/dy, dv/dy) -> (m, 5) rows (P, a, b, r, phi) and status codes.
        const auto m_rows = static_cast<std::size_t>(jac.size() / 4);
        py::array_t<double> shapes({static_cast<py::ssize_t>(m_rows), static_cast<py::ssize_t>(5)});
        py::array_t<std::uint8_t> status(static_cast<py::ssize_t>(m_rows));
        const double* j = jac.data();
        double* o = shapes.mutable_data();
        std::uint8_t* st = status.mutable_data();
        for (std::size_t i = 0; i < m_rows; ++i) {
          const aniso::Shape s = aniso::shape_from_jacobian(j[4 * i], j[4 * i + 1], j[4 * i + 2], j[4 * i + 3]);
          o[5 * i] = s.area, o[5 * i + 1] = s.major, o[5 * i + 2] = s.minor, o[5 * i + 3] = s.ratio,
                o[5 * i + 4] = s.angle;
          st[i] = static_cast<std::uint8_t>(s.status);
        }
        return py::make_tuple(shapes, status);
      },
      py::arg("jac"));
  py::class_<aniso::AnisoCounter, std::shared_ptr<aniso::AnisoCounter>>(m, "AnisoCounter")
      .def_property_readonly("scheme_name", [](const aniso::AnisoCounter& c) { return c.scheme().name(); })
      .def_property_readonly("scheme_params",
                             [](const aniso::AnisoCounter& c) { return from_params(c.scheme().params()); })
      .def_property_readonly("evaluations_per_term", &aniso::AnisoCounter::evaluations_per_term)
      .def_property_readonly("integer_output", &aniso::AnisoCounter::integer_output)
      .def_property_readonly("has_pmf", &aniso::AnisoCounter::has_pmf)
      .def(
          "terms",
          [](const aniso::AnisoCounter& c, double density, double area, double ratio, double angle) {
            bool clamped = false;
            const auto ts = c.terms(density, aniso::shape_from_params(area, ratio, angle), &clamped);
            py::list rows;
            for (const auto& t : ts) {
              py::dict d;
              d["scale_level"] = t.grid.scale;
              d["ratio_level"] = t.grid.ratio;
              d["orientation"] = t.grid.orientation;
              d["angle"] = t.angle;
              d["cell_minor"] = t.cell_minor;
              d["cell_major"] = t.cell_major;
              d["cell_area"] = t.cell_area;
              d["dx"] = t.dx;
              d["dy"] = t.dy;
              d["weight"] = t.weight;
              d["trials"] = t.trials;
              d["scale"] = t.scale;
              rows.append(d);
            }
            return py::make_tuple(rows, clamped);
          },
          py::arg("N"), py::arg("P"), py::arg("r"), py::arg("phi"))
      .def(
          "pmf",
          [](const aniso::AnisoCounter& c, double density, double area, double ratio, double angle, double p,
             std::size_t max_support) {
            const auto shape = aniso::shape_from_params(area, ratio, angle);
            LongCall release;
            return c.pmf(density, p, shape, max_support);
          },
          py::arg("N"), py::arg("P"), py::arg("r"), py::arg("phi"), py::arg("p"),
          py::arg("max_support") = kDefaultMaxSupport)
      .def(
          "sample",
          [](const aniso::AnisoCounter& c, double density, double area, double ratio, double angle, double p,
             std::size_t count, std::uint64_t seed, const py::object& out_arg) {
            const auto shape = aniso::shape_from_params(area, ratio, angle);
            OutArray out = output_array(out_arg, count);
            double* o = out.mutable_data();
            {
              LongCall release;
              c.sample(density, p, shape, count, seed, o);
            }
            return out;
          },
          py::arg("N"), py::arg("P"), py::arg("r"), py::arg("phi"), py::arg("p"), py::arg("count"), py::arg("seed"),
          py::arg("out") = py::none())
      .def(
          "count_pixels",
          [](const aniso::AnisoCounter& c, double density, const Array& p, const Array& uv, const Array& jac,
             std::optional<Array> slope, std::uint64_t seed) {
            const auto m_rows = static_cast<std::size_t>(uv.size() / 2);
            if (static_cast<std::size_t>(jac.size()) != 4 * m_rows)
              glintlab::throw_invalid_message("J has " + std::to_string(jac.size() / 4) + " pixels; uv has " +
                                              std::to_string(m_rows));
            if (slope && static_cast<std::size_t>(slope->size()) != 2 * m_rows)
              glintlab::throw_invalid_message("slope has " + std::to_string(slope->size() / 2) + " pixels; uv has " +
                                              std::to_string(m_rows));
            const auto rows = static_cast<py::ssize_t>(m_rows);
            py::array_t<double> k(rows);
            py::array_t<std::int32_t> evals(rows);
            py::array_t<std::uint8_t> status(rows);
            aniso::PixelOutput out{k.mutable_data(), evals.mutable_data(), status.mutable_data()};
            const double* sl = slope ? slope->data() : nullptr;
            {
              LongCall release;
              c.count_pixels(density, param(p), uv.data(), jac.data(), sl, m_rows, seed, out);
            }
            return py::make_tuple(k, evals, status);
          },
          py::arg("N"), py::arg("p"), py::arg("uv"), py::arg("jac"), py::arg("slope"), py::arg("seed"));
  auto options = [](const std::string& spatial, const std::string& angular, const std::string& realization) {
    return aniso::CounterOptions{aniso::spatial_from_name(spatial), aniso::angular_from_name(angular),
                                 aniso::realization_from_name(realization)};
  };
  m.def(
      "make_aniso_counter",
      [options](const std::string& scheme, const py::dict& kwargs, std::shared_ptr<CountingLaw> inner,
                const std::string& spatial, const std::string& angular, const std::string& realization) {
        std::shared_ptr<const aniso::GridScheme> s = aniso::make_grid_scheme(scheme, to_params(kwargs));
        return std::make_shared<aniso::AnisoCounter>(s, InnerLaw::from_law(std::move(inner)),
                                                     options(spatial, angular, realization));
      },
      py::arg("scheme"), py::arg("params"), py::arg("inner"), py::arg("spatial"), py::arg("angular"),
      py::arg("realization"));
  m.def(
      "make_aniso_counter_custom",
      [options](const std::string& scheme, const py::dict& kwargs, py::function fn, int n_uniforms,
                const std::string& inner_name, const std::string& spatial, const std::string& angular,
                const std::string& realization) {
        std::shared_ptr<const aniso::GridScheme> s = aniso::make_grid_scheme(scheme, to_params(kwargs));
        return std::make_shared<aniso::AnisoCounter>(s, python_inner(fn, n_uniforms, inner_name),
                                                     options(spatial, angular, realization));
      },
      py::arg("scheme"), py::arg("params"), py::arg("fn"), py::arg("n_uniforms"), py::arg("inner_name"),
      py::arg("spatial"), py::arg("angular"), py::arg("realization"));
}
