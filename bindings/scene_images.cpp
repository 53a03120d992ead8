// Glint images of scenes: the facet-by-facet ground truth (core/include/glintlab/glinty/glint_image.hpp).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/glint_image.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_scene_images(py::module_& m) {
  using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
  m.def(
      "facet_counts",
      [](double density, const Array& p, const Array& uv, const Array& jac, std::optional<Array> slope,
         std::uint64_t seed, double max_cells) {
        const auto rows = static_cast<std::size_t>(uv.size() / 2);
        if (static_cast<std::size_t>(jac.size()) != 4 * rows)
          glintlab::throw_invalid_message("J has " + std::to_string(jac.size() / 4) + " pixels; uv has " +
                                          std::to_string(rows));
        if (slope && static_cast<std::size_t>(slope->size()) != 2 * rows)
          glintlab::throw_invalid_message("slope has " + std::to_string(slope->size() / 2) + " pixels; uv has " +
                                          std::to_string(rows));
        const auto n = static_cast<py::ssize_t>(rows);
        py::array_t<double> k(n), tested(n);
        py::array_t<std::uint8_t> status(n);
        const double* sl = slope ? slope->data() : nullptr;
        {
          glintlab::bindings::LongCall release;
          images::facet_counts(density, p.data(), static_cast<std::size_t>(p.size()), uv.data(), jac.data(), sl, rows,
                               seed, max_cells, k.mutable_data(), status.mutable_data(), tested.mutable_data());
        }
        return py::make_tuple(k, status, tested);
      },
      py::arg("density"), py::arg("p"), py::arg("uv"), py::arg("jac"), py::arg("slope"), py::arg("seed"),
      py::arg("max_cells"),
      "Stratified facets reflecting in each pixel's footprint ellipse: (K, status, facets tested).");
}

}  // namespace glintlab::bindings
