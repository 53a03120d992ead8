// The conversions between numpy / Python values and the core's types that several binding files share:
// parameter arrays, output arrays, a law's parameters, and an inner law written in Python.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "glintlab/counting/blend.hpp"
#include "glintlab/counting/law.hpp"

namespace glintlab::bindings {

// A float64 array in (converted and made C-contiguous if it is not).
using Array = pybind11::array_t<double, pybind11::array::c_style | pybind11::array::forcecast>;
// A float64 array out, written in place (never a converted copy).
using OutArray = pybind11::array_t<double, pybind11::array::c_style>;

pybind11::array_t<double> to_numpy(const std::vector<double>& v);

// One of the vectorized drivers' parameter arrays (1 element: broadcast).
ParamArray param(const Array& a);

// A sampler's output: the caller's preallocated `out` (a writeable C-contiguous float64 array of
// `count` elements; the Python layer checks its shape and names it) or a fresh array. Never a copy.
OutArray output_array(const pybind11::object& out, std::size_t count);

// A law's (or blend's, or grid scheme's) keyword parameters: strings stay strings, booleans are 1 or 0,
// anything else must convert to a number.
LawParams to_params(const pybind11::dict& kwargs);
pybind11::dict from_params(const LawParams& params);

// An inner law written in Python: fn(n, p, u) -> counts, called on the calling thread with the GIL.
InnerLaw python_inner(pybind11::function fn, int n_uniforms, const std::string& inner_name);

}  // namespace glintlab::bindings
