// Distribution (glintlab/stats/distribution.hpp): a law's exact pmf on its support, as numpy arrays; pickles
// exactly.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/stats/distribution.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

std::string distribution_repr(const Distribution& d) {
  std::string s = "Distribution(" + std::to_string(d.size()) + " points";
  if (d.size() > 0) s += " in [" + format_value(d.support().front()) + ", " + format_value(d.support().back()) + "]";
  s += ", mean=" + format_value(d.mean()) + ", var=" + format_value(d.var());
  if (d.trimmed_below() || d.trimmed_above())
    s += std::string(", tails trimmed") + (d.trimmed_below() ? " below" : "") +
         (d.trimmed_below() && d.trimmed_above() ? " and" : "") + (d.trimmed_above() ? " above" : "");
  return s + ")";
}

}  // namespace

void bind_distribution(py::module_& m) {
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
      .def("__repr__", &distribution_repr)
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
}

}  // namespace glintlab::bindings
