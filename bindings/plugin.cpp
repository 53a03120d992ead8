// C++ plugin laws (glintlab/validation/plugin.hpp, glintlab/plugin.h); `reserved`: the names of the
// Python custom laws, which a plugin may not take.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "glintlab/validation/plugin.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_plugins(py::module_& m) {
  m.def("load_plugin", &load_plugin, py::arg("path"), py::arg("reserved"));
  m.def("loaded_plugins", [] {
    std::vector<std::pair<std::string, std::vector<std::string>>> out;
    for (const auto& p : loaded_plugins()) out.emplace_back(p.path, p.laws);
    return out;
  });
}

}  // namespace glintlab::bindings
