// The core's errors and interrupts (glintlab/base/errors.hpp): not_implemented raises NotImplementedError,
// `interrupted` (a batch driver stopped by Ctrl-C, see LongCall) raises KeyboardInterrupt, and a sweep's
// thread pool asks the running C++ batches to stop with request_interrupt.
#include <pybind11/pybind11.h>

#include <exception>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

void bind_errors(py::module_& m) {
  py::register_exception<not_implemented>(m, "NotImplementedErrorCore", PyExc_NotImplementedError);
  g_main_thread = py::module_::import("threading").attr("main_thread")().attr("ident").cast<unsigned long>();
  py::register_exception_translator([](std::exception_ptr error) {
    try {
      if (error) std::rethrow_exception(error);
    } catch (const interrupted&) { PyErr_SetNone(PyExc_KeyboardInterrupt); }
  });
  // A sweep's thread pool: on Ctrl-C the main thread asks the running C++ batches to stop.
  m.def("request_interrupt", &request_interrupt);
  m.def("clear_interrupt", &clear_interrupt);
}

}  // namespace glintlab::bindings
