// Thin pybind11 layer over glintlab::core. Broadcasting, argument checks, defaults and docstrings live
// in the Python package (glintlab/api/: checks.py broadcasts n and p, laws.py and the other api modules
// wrap these functions); the binding files only convert arrays, release the GIL around long calls
// and map C++ exceptions (std::invalid_argument -> ValueError, not_implemented -> NotImplementedError).
// This file assembles the module from one binding file per core or validation module (bindings.hpp).
// The order matters: a class is registered before the functions whose signatures name it, so that their
// docstrings say glintlab._core.Distribution rather than the C++ type.
#include <pybind11/pybind11.h>

#include "bindings.hpp"

namespace py = pybind11;
namespace gb = glintlab::bindings;

PYBIND11_MODULE(_core, m) {
  m.doc() = "glintlab C++ core (use the glintlab package, not this module)";
  m.attr("__version__") = GLINTLAB_VERSION;
  gb::bind_errors(m);
  gb::bind_glinty_ndf(m);
  gb::bind_shaders(m);
  gb::bind_wwh18(m);
  gb::bind_method_shaders(m);
  gb::bind_sampler_test(m);
  gb::bind_sampler_shaders(m);
  gb::bind_wb16(m);
  gb::bind_scene_trace(m);
  gb::bind_lighting(m);
  gb::bind_documents(m);
  gb::bind_scene_images(m);
  gb::bind_distribution(m);
  gb::bind_laws(m);
  gb::bind_plugins(m);
  gb::bind_metrics(m);
  gb::bind_chi2(m);
  gb::bind_uniforms_and_threads(m);
  gb::bind_binomial(m);
  gb::bind_spatial(m);
  gb::bind_blends(m);
  gb::bind_aniso(m);
  gb::bind_gpu_cost(m);
}
