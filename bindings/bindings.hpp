// The pybind11 module glintlab._core is one module assembled from one binding file per core or validation
// module: module.cpp calls each file's bind_* function declared here, and a file's bind_* calls a few
// short functions (each under 80 lines, tests/python/test_limits.py). A new topic is a new
// bindings/<topic>.cpp defining its bind_* (CMake globs the folder) and one call in module.cpp. The
// conversions several files share (numpy arrays, law parameters, a Python inner law) are in
// conversions.hpp.
#pragma once

#include <pybind11/pybind11.h>

#include <csignal>
#include <exception>
#include <optional>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/validation/dispatch_timing.hpp"

namespace glintlab::shader {
class Kernel;
}

namespace glintlab::bindings {

inline unsigned long g_main_thread = 0;  // PyThread_get_thread_ident() of the thread that imported _core

inline void on_sigint(int) noexcept { request_interrupt(); }

// A call into the C++ core that may run long: releases the GIL and, on the main thread, makes Ctrl-C
// work. Python handles SIGINT only between bytecodes, never while C++ runs, so for the duration of
// the call SIGINT sets the core's interrupt flag instead (the batch drivers stop at their next chunk
// and throw `interrupted`, raised as KeyboardInterrupt); the previous handler is restored after. A
// request that arrives after the last chunk is handed to Python (PyErr_SetInterrupt), not lost.
class LongCall {
 public:
  LongCall() : exceptions_(std::uncaught_exceptions()), installed_(install(previous_)) {}
  // Runs before release_ is destroyed, i.e. still without the GIL: sigaction and PyErr_SetInterrupt
  // need none.
  ~LongCall() {
    if (!installed_) return;
    sigaction(SIGINT, &previous_, nullptr);
    if (interrupt_requested() && std::uncaught_exceptions() == exceptions_) PyErr_SetInterrupt();
    clear_interrupt();
  }
  LongCall(const LongCall&) = delete;
  LongCall& operator=(const LongCall&) = delete;

 private:
  static bool install(struct sigaction& previous) {
    if (PyThread_get_thread_ident() != g_main_thread) return false;  // Python signals reach the main thread only
    clear_interrupt();
    struct sigaction action {};
    action.sa_handler = on_sigint;
    sigemptyset(&action.sa_mask);
    return sigaction(SIGINT, &action, &previous) == 0;
  }

  int exceptions_;
  struct sigaction previous_ {};
  bool installed_;
  pybind11::gil_scoped_release release_;  // last: released after the handler is in place, taken back last
};

// Runs `call` as a LongCall (the GIL released, Ctrl-C honoured); with `timing`, its thread's dispatches
// timed (shader::DispatchTiming): their milliseconds, else an empty list.
template <class F>
std::vector<double> long_call_timed(bool timing, F&& call) {
  LongCall release;
  std::optional<shader::DispatchTiming> timer;
  if (timing) timer.emplace();
  call();
  return timer ? timer->milliseconds() : std::vector<double>{};
}

// shaders.cpp: a kernel's declared resources as a list of dicts, and data bound to them from a list of
// dicts (name, levels, extent, channels, filter, address); shared by every kind of shader kernel.
pybind11::list declared_resources(const glintlab::shader::Kernel& k);
void bind_resources(glintlab::shader::Kernel& k, const pybind11::list& data);

void bind_errors(pybind11::module_& m);                // errors.cpp: NotImplementedError, Ctrl-C, interrupts
void bind_documents(pybind11::module_& m);             // documents.cpp: experiment and bounds documents
void bind_distribution(pybind11::module_& m);          // distribution.cpp: Distribution
void bind_laws(pybind11::module_& m);                  // law.cpp: CoreLaw, the law registry and traits
void bind_uniforms_and_threads(pybind11::module_& m);  // law.cpp: batch uniforms, threads, SIMD level
void bind_plugins(pybind11::module_& m);               // plugin.cpp: C++ plugin laws
void bind_metrics(pybind11::module_& m);               // metrics.cpp: distances between distributions
void bind_chi2(pybind11::module_& m);                  // chi2.cpp: the chi-square test and its result
void bind_binomial(pybind11::module_& m);              // binomial.cpp: exact binomial and Poisson functions
void bind_spatial(pybind11::module_& m);               // spatial.cpp: footprints and the ground truth
void bind_blends(pybind11::module_& m);                // blend.cpp: BlendedLaw and the blend registry
void bind_aniso(pybind11::module_& m);                 // aniso.cpp: grid schemes and AnisoCounter

void bind_scene_images(pybind11::module_& m);     // scene_images.cpp: the glint images' ground truth
void bind_glinty_ndf(pybind11::module_& m);       // glinty_ndf.cpp: KPT25's glinty NDF
void bind_shaders(pybind11::module_& m);          // shaders.cpp: shader laws, the Vulkan runner
void bind_wwh18(pybind11::module_& m);            // wwh18.cpp: WWH18's filterable model and its flake truth
void bind_method_shaders(pybind11::module_& m);   // method_shaders.cpp: per-pixel method shaders
void bind_sampler_test(pybind11::module_& m);     // sampler_test.cpp: the direction-sampler harness
void bind_sampler_shaders(pybind11::module_& m);  // sampler_shaders.cpp: direction samplers written as shaders
void bind_wb16(pybind11::module_& m);             // wb16.cpp: WB16's sparkle shader's C++ twin
void bind_scene_trace(pybind11::module_& m);      // scene_trace.cpp: Scene.trace's camera rays
void bind_gpu_cost(pybind11::module_& m);         // gpu_cost.cpp: RADV null devices as a GPU compiler
void bind_lighting(pybind11::module_& m);         // lighting.cpp: area lights, environment maps, their facet truth

}  // namespace glintlab::bindings
