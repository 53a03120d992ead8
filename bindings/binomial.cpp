// The exact binomial and Poisson distribution functions (glintlab/stats/binomial.hpp), vectorized with numpy
// broadcasting.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "glintlab/stats/binomial.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_binomial(py::module_& m) {
  m.def("binomial_log_pmf", py::vectorize(&binomial::log_pmf), py::arg("k"), py::arg("n"), py::arg("p"));
  m.def("binomial_cdf", py::vectorize(&binomial::cdf), py::arg("k"), py::arg("n"), py::arg("p"));
  m.def("binomial_sf", py::vectorize(&binomial::sf), py::arg("k"), py::arg("n"), py::arg("p"));
  m.def("binomial_quantile", py::vectorize(&binomial::quantile), py::arg("u"), py::arg("n"), py::arg("p"));
  m.def("poisson_log_pmf", py::vectorize(&poisson::log_pmf), py::arg("k"), py::arg("lam"));
  m.def("poisson_cdf", py::vectorize(&poisson::cdf), py::arg("k"), py::arg("lam"));
  m.def("poisson_sf", py::vectorize(&poisson::sf), py::arg("k"), py::arg("lam"));
  m.def("poisson_quantile", py::vectorize(&poisson::quantile), py::arg("u"), py::arg("lam"));
}

}  // namespace glintlab::bindings
