// Distances between distributions (glintlab/stats/metrics.hpp).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "bindings.hpp"
#include "glintlab/stats/metrics.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_metrics(py::module_& m) {
  m.def("metric_names", &metric_names);
  m.def(
      "distance",
      [](const Distribution& a, const Distribution& b, const std::string& metric) {
        const Metric mm = metric_from_name(metric);
        LongCall release;
        return distance(a, b, mm);
      },
      py::arg("a"), py::arg("b"), py::arg("metric"));
}

}  // namespace glintlab::bindings
