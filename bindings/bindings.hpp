// The pybind11 module glintlab._core is one module assembled from one file per topic: module.cpp (laws,
// blends, grids, statistics, documents, plugins) calls each topic's bind_* function declared here. A new
// topic is a new bindings/<topic>.cpp defining its bind_* and one call in module.cpp.
#pragma once

#include <pybind11/pybind11.h>

namespace glintlab::bindings {

void bind_scene_images(pybind11::module_& m);  // scene_images.cpp: the glint images' ground truth
void bind_glinty_ndf(pybind11::module_& m);  // glinty_ndf.cpp: KPT25's glinty NDF
void bind_shaders(pybind11::module_& m);  // shaders.cpp: shader laws, the Vulkan runner

}  // namespace glintlab::bindings
