// WB16's sparkle shader's C++ twin (core/include/glintlab/glinty/wb16.hpp) as _core.wb16_twin: (rows, 32) uint32
// packed GlintInput rows in, (rows,) float32 intensities and (rows, 3) float32 lookup positions out.
// glintlab.api.method_shaders.wb16_twin checks the parameters' names and passes them here.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/wb16.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_wb16(py::module_& m) {
  using Rows = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>;
  m.def(
      "wb16_twin",
      [](const Rows& rows, double sparkle_size, double sparkle_density, double view_dep, double noise_amount,
         double noise_density, double unit, int shape, double shopf_k, int noise, int anisotropic,
         double kernel_scale) {
        if (rows.ndim() != 2 || rows.shape(1) != static_cast<py::ssize_t>(wb16::kInputWords))
          glintlab::throw_invalid_message("rows is not an array of shape (m, " + std::to_string(wb16::kInputWords) +
                                          ")");
        const wb16::Params params{sparkle_size, sparkle_density, view_dep, noise_amount, noise_density, unit,
                                  shape,        shopf_k,         noise,    anisotropic,  kernel_scale};
        const auto count = static_cast<py::ssize_t>(rows.shape(0));
        py::array_t<float> out(count);
        py::array_t<float> pos({count, static_cast<py::ssize_t>(3)});
        {
          glintlab::bindings::LongCall release;
          wb16::twin(rows.data(), static_cast<std::size_t>(count), params, out.mutable_data(), pos.mutable_data());
        }
        return py::make_tuple(out, pos);
      },
      py::arg("rows"), py::arg("sparkle_size"), py::arg("sparkle_density"), py::arg("view_dep"),
      py::arg("noise_amount"), py::arg("noise_density"), py::arg("unit"), py::arg("shape"), py::arg("shopf_k"),
      py::arg("noise"), py::arg("anisotropic"), py::arg("kernel_scale"));
}

}  // namespace glintlab::bindings
