// The chi-square test of samples against an exact law (glintlab/stats/chi2.hpp): Chi2Result unpacks as
// (statistic, pvalue), like scipy's result, and pickles.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/stats/chi2.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

using Chi2Class = py::class_<Chi2Result>;

void bind_chi2_construction(Chi2Class& result) {
  result
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
}

// Unpacks like scipy's result: `statistic, pvalue = gl.chi2_test(...)`.
void bind_chi2_unpacking(Chi2Class& result) {
  result.def("__len__", [](const Chi2Result&) { return 2; })
      .def("__getitem__",
           [](const Chi2Result& r, long i) {
             if (i == 0 || i == -2) return r.statistic;
             if (i == 1 || i == -1) return r.pvalue;
             throw py::index_error("Chi2Result unpacks as (statistic, pvalue); index " + std::to_string(i));
           })
      .def("__iter__", [](const Chi2Result& r) { return py::iter(py::make_tuple(r.statistic, r.pvalue)); })
      .def("__repr__", [](const Chi2Result& r) {
        std::string s = "Chi2Result(statistic=" + format_value(r.statistic) + ", pvalue=" + format_value(r.pvalue) +
                        ", dof=" + std::to_string(r.dof) + ", samples=" + std::to_string(r.samples);
        if (!r.note.empty()) s += ", note=" + py::repr(py::str(r.note)).cast<std::string>();
        return s + ")";
      });
}

void bind_chi2_result(py::module_& m) {
  Chi2Class result(m, "Chi2Result",
                   "A chi-square test's result: statistic, pvalue, dof, samples, note (why the test is "
                   "degenerate or failed outright) and the merged bins (lower, upper, observed, expected). "
                   "Unpacks as (statistic, pvalue), like scipy's.");
  result.def_readonly("statistic", &Chi2Result::statistic)
      .def_readonly("dof", &Chi2Result::dof)
      .def_readonly("pvalue", &Chi2Result::pvalue)
      .def_readonly("samples", &Chi2Result::samples)
      .def_readonly("note", &Chi2Result::note)
      .def_property_readonly("lower", [](const Chi2Result& r) { return to_numpy(r.lower); })
      .def_property_readonly("upper", [](const Chi2Result& r) { return to_numpy(r.upper); })
      .def_property_readonly("observed", [](const Chi2Result& r) { return to_numpy(r.observed); })
      .def_property_readonly("expected", [](const Chi2Result& r) { return to_numpy(r.expected); })
      .def_readonly("resolution", &Chi2Result::resolution,
                    "the p-value's resolution: 0 when computed, 1 / (1 + draws) for a Monte Carlo estimate");
  bind_chi2_construction(result);
  bind_chi2_unpacking(result);
}

}  // namespace

void bind_chi2(py::module_& m) {
  bind_chi2_result(m);
  m.def(
      "chi2_test",
      [](const Array& samples, const Distribution& law, double min_expected, int fitted_params, double alpha) {
        LongCall release;
        return chi2_test(samples.data(), static_cast<std::size_t>(samples.size()), law, min_expected, fitted_params,
                         alpha);
      },
      py::arg("samples"), py::arg("law"), py::arg("min_expected"), py::arg("fitted_params"), py::arg("alpha") = 0.0);
  m.def("sidak_alpha", &sidak_alpha, py::arg("alpha"), py::arg("tests"));
}

}  // namespace glintlab::bindings
