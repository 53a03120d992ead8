// The pybind11 module glintlab._core is one module assembled from one file per topic: module.cpp (laws,
// blends, grids, statistics, documents, plugins) calls each topic's bind_* function declared here. A new
// topic is a new bindings/<topic>.cpp defining its bind_* and one call in module.cpp.
#pragma once

#include <pybind11/pybind11.h>

namespace glintlab::bindings {

// Shader laws: the Vulkan runner (bindings/shaders.cpp).
void bind_shaders(pybind11::module_& m);

}  // namespace glintlab::bindings
