// The shared conversions of conversions.hpp.
#include "conversions.hpp"

#include <cstring>

#include "glintlab/base/errors.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

py::array_t<double> to_numpy(const std::vector<double>& v) {
  py::array_t<double> out(static_cast<py::ssize_t>(v.size()));
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(double));
  return out;
}

ParamArray param(const Array& a) { return {a.data(), static_cast<std::size_t>(a.size())}; }

OutArray output_array(const py::object& out, std::size_t count) {
  if (out.is_none()) return OutArray(static_cast<py::ssize_t>(count));
  if (!py::isinstance<OutArray>(out))
    glintlab::throw_invalid_message("out is not a C-contiguous float64 array; expected one of " +
                                    std::to_string(count) + " elements");
  auto a = py::reinterpret_borrow<OutArray>(out);
  if (static_cast<std::size_t>(a.size()) != count)
    glintlab::throw_invalid_message("out has " + std::to_string(a.size()) + " elements; expected " +
                                    std::to_string(count));
  if (!a.writeable()) glintlab::throw_invalid_message("out is read-only; expected a writeable float64 array");
  return a;
}

LawParams to_params(const py::dict& kwargs) {
  LawParams params;
  for (auto item : kwargs) {
    const auto key = py::str(item.first).cast<std::string>();
    if (py::isinstance<py::str>(item.second)) {
      params[key] = item.second.cast<std::string>();
    } else if (py::isinstance<py::bool_>(item.second)) {
      params[key] = item.second.cast<bool>() ? 1.0 : 0.0;
    } else {
      try {
        params[key] = item.second.cast<double>();
      } catch (const py::cast_error&) {
        glintlab::throw_invalid_message("law parameter " + key + " = " + py::repr(item.second).cast<std::string>() +
                                        " is invalid; expected a number or a string");
      }
    }
  }
  return params;
}

py::dict from_params(const LawParams& params) {
  py::dict d;
  for (const auto& [k, v] : params) {
    if (const double* x = std::get_if<double>(&v))
      d[py::str(k)] = *x;
    else
      d[py::str(k)] = std::get<std::string>(v);
  }
  return d;
}

InnerLaw python_inner(py::function fn, int n_uniforms, const std::string& inner_name) {
  InnerLaw inner;
  inner.name = inner_name;
  inner.n_uniforms = n_uniforms;
  inner.integer_output = false;  // unknown: samples are binned, no exact pmf
  inner.thread_safe = false;
  const auto k = static_cast<py::ssize_t>(n_uniforms);
  inner.evaluate = [fn, k](const double* n, const double* p, const double* u, std::size_t rows_count, double* out) {
    py::gil_scoped_acquire acquire;
    const auto rows = static_cast<py::ssize_t>(rows_count);
    py::array_t<double> na(rows), pa(rows), ua({rows, k});
    std::memcpy(na.mutable_data(), n, rows_count * sizeof(double));
    std::memcpy(pa.mutable_data(), p, rows_count * sizeof(double));
    if (k > 0) std::memcpy(ua.mutable_data(), u, rows_count * static_cast<std::size_t>(k) * sizeof(double));
    const auto result = fn(na, pa, ua).cast<Array>();
    if (result.size() != rows)
      glintlab::throw_invalid_message("custom inner law returned " + std::to_string(result.size()) +
                                      " values; expected " + std::to_string(rows_count));
    std::memcpy(out, result.data(), rows_count * sizeof(double));
  };
  return inner;
}

}  // namespace glintlab::bindings
