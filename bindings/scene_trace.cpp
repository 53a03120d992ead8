// Scene.trace's per-ray work in C++ (core/include/glintlab/scene/scene_trace.hpp) as _core.scene_trace: the
// scene's camera and primitive as plain numbers (glintlab.validation.scene.Scene passes its own), flat
// float64 pixel coordinates in, a dict of arrays out (Scene.trace reshapes them).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/scene/scene_trace.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_scene_trace(py::module_& m) {
  using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
  using V3 = std::array<double, 3>;
  m.def(
      "scene_trace",
      [](const Array& px, const Array& py_, bool sphere, double width, double height, double focal, V3 position,
         V3 forward, V3 right, V3 up, V3 center, double radius, V3 origin, V3 normal, V3 e1, V3 e2,
         std::vector<std::array<double, 5>> waves, double uv_scale) {
        if (px.size() != py_.size())
          glintlab::throw_invalid_message("px has " + std::to_string(px.size()) + " values; py has " +
                                          std::to_string(py_.size()));
        images::TraceScene s{sphere, width,  height, focal, position, forward,          right,   up, center,
                             radius, origin, normal, e1,    e2,       std::move(waves), uv_scale};
        const auto n = static_cast<py::ssize_t>(px.size());
        auto arr = [n](py::ssize_t k) { return k == 1 ? py::array_t<double>(n) : py::array_t<double>({n, k}); };
        py::array_t<std::uint8_t> hit(n);
        auto t = arr(1), x = arr(3), uv = arr(2), J = arr(4), shading = arr(3), direction = arr(3), dxdpx = arr(3),
             dxdpy = arr(3);
        const images::TraceOut out{hit.mutable_data(),       t.mutable_data(),     x.mutable_data(),
                                   uv.mutable_data(),        J.mutable_data(),     shading.mutable_data(),
                                   direction.mutable_data(), dxdpx.mutable_data(), dxdpy.mutable_data()};
        {
          glintlab::bindings::LongCall release;
          images::trace(s, px.data(), py_.data(), static_cast<std::size_t>(n), out);
        }
        py::dict d;
        d["hit"] = hit;
        d["t"] = t;
        d["x"] = x;
        d["uv"] = uv;
        d["J"] = J;
        d["shading_normal"] = shading;
        d["direction"] = direction;
        d["dxdpx"] = dxdpx;
        d["dxdpy"] = dxdpy;
        return d;
      },
      py::arg("px"), py::arg("py"), py::arg("sphere"), py::arg("width"), py::arg("height"), py::arg("focal"),
      py::arg("position"), py::arg("forward"), py::arg("right"), py::arg("up"), py::arg("center"), py::arg("radius"),
      py::arg("origin"), py::arg("normal"), py::arg("e1"), py::arg("e2"), py::arg("waves"), py::arg("uv_scale"));
}

}  // namespace glintlab::bindings
