// Experiment and bounds documents (glintlab/validation/documents.hpp): the normalized document as JSON
// text; bad input raises InputError (a ValueError) "<source>: at <pointer>: expected ..., got ...".
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <string_view>

#include "bindings.hpp"
#include "glintlab/validation/documents.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_documents(py::module_& m) {
  py::register_exception<validation::InputError>(m, "InputError", PyExc_ValueError);
  m.def(
      "parse_document",
      [](const std::string& kind, std::string_view text, const std::string& source) {
        return validation::parse_document(kind, text, source).dump();
      },
      py::arg("kind"), py::arg("text"), py::arg("source"));
  m.def("schema_text", &validation::schema_text, py::arg("name"));
}

}  // namespace glintlab::bindings
