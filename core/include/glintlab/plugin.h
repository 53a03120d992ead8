/* glintlab plugin ABI, version 1: counting laws written in C or C++, loaded at run time.
 *
 * A plugin is a shared library that includes only this header (it needs no glintlab library and
 * no other glintlab header) and exports one function:
 *
 *     const glintlab_law_v1* glintlab_plugin_laws_v1(int* count);
 *
 * returning a table of *count law descriptions that stays valid while the library is loaded (a
 * static array). glintlab::load_plugin (C++) or glintlab.load_plugin (Python) opens the library,
 * validates the table and registers each entry under its name; from then on the law is used like a
 * built-in one: glintlab.law("my_law").sample(n, p, size, seed), .evaluate, .pmf, reports, bounds,
 * sweeps, chi-square tests. A library stays loaded for the life of the process (registered laws
 * point at its code); loading the same file again returns the same names and changes nothing.
 *
 * Minimal plugin (C++; in C the table entries are plain initializers, see GLINTLAB_PLUGIN below):
 *
 *     #include "glintlab/plugin.h"
 *     static double all_or_nothing(double n, double p, const double* u) noexcept {
 *       return u[0] < p ? n : 0.0;
 *     }
 *     GLINTLAB_PLUGIN(
 *         glintlab::plugin::law("all_or_nothing", "every facet reflects, or none", 1, all_or_nothing))
 *
 *     g++ -O2 -shared -fPIC -I <glintlab>/core/include my_law.cpp -o libmy_law.so
 *
 * CONTRACT of the callbacks (glintlab relies on it; violations are not all detectable):
 *
 *  - Inputs are validated before any call: n is finite and >= 0 (non-integer n is allowed: a law
 *    states its own rule for it), p is in [0, 1], and each u[i] is in [0, 1] (the samplers pass
 *    (0, 1); explicit law.evaluate(n, p, u) may pass the end points 0 and 1). Each callback must
 *    return a meaningful result for every such input.
 *  - Thread safety: evaluate and pmf are called concurrently from several threads (OpenMP). They
 *    must be reentrant: no writable global or static state, no locale- or errno-dependent results.
 *    (In glibc, lgamma() writes the global `signgam`: use lgamma_r or avoid it.)
 *  - Determinism: the same arguments must give the same bits at every call. glintlab's promise
 *    "same seed, same samples, whatever the number of threads" holds for a plugin law only then.
 *  - No exceptions: this is a C interface, an exception escaping a callback is undefined
 *    behaviour (std::terminate at best). Mark C++ callbacks noexcept.
 *  - Bad values: the C++ hot path passes evaluate's result through unchanged, and the Python layer
 *    then refuses a NaN or infinite K from a plugin law (ValueError naming the law and the row), as
 *    it does for a Python custom law; the extremes suite reports such outputs too. Counts outside
 *    [0, ceil(n)] are not refused (some shader laws produce them).
 *    pmf's output IS checked: every probability finite and >= 0 and their sum within 1e-9 of 1,
 *    otherwise the call fails (std::runtime_error, Python RuntimeError) naming the law and (n, p).
 *
 * ABI versioning: the struct below is frozen. A future version would add glintlab_law_v2 and
 * glintlab_plugin_laws_v2 next to these; a loader keeps accepting v1 plugins.
 */
#ifndef GLINTLAB_PLUGIN_H
#define GLINTLAB_PLUGIN_H

#define GLINTLAB_PLUGIN_ABI_VERSION 1

/* Entry-point symbol name, for loaders (dlsym). */
#define GLINTLAB_PLUGIN_SYMBOL_V1 "glintlab_plugin_laws_v1"

/* Bits of *trimmed (see pmf below). */
#define GLINTLAB_TRIMMED_BELOW 1 /* some mass (< 1e-9) lies below first_k */
#define GLINTLAB_TRIMMED_ABOVE 2 /* some mass (< 1e-9) lies above the last point */

/* pmf return codes other than a length >= 1. */
#define GLINTLAB_PMF_CAPACITY (-1) /* probs too small: call again with a larger capacity */
#define GLINTLAB_PMF_NONE (-2)     /* no exact law at this (n, p) */

#if defined(_WIN32)
#define GLINTLAB_PLUGIN_EXPORT __declspec(dllexport)
#else
/* Exported even when the plugin is compiled with -fvisibility=hidden. */
#define GLINTLAB_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
#define GLINTLAB_PLUGIN_EXTERN_C extern "C"
extern "C" {
#else
#define GLINTLAB_PLUGIN_EXTERN_C
#endif

typedef struct glintlab_law_v1 {
  /* Registry name: 1 to 64 characters [A-Za-z0-9_.-], starting with a letter; must not be the name
   * of a law already registered (built-in, another plugin, a Python custom law). */
  const char* name;
  /* One line for listings (glintlab.law_summaries()); NULL means "". */
  const char* summary;
  /* Uniforms one evaluation consumes: 0 to 4. */
  int n_uniforms;
  /* How outputs are binned for pmf and comparisons: "none" (evaluate returns integer counts) or
   * "round" (real outputs, binned round half up: unit bins [k - 1/2, k + 1/2)). NULL means "none". */
  const char* binning;
  /* K from (n, p) and u[0 .. n_uniforms) (u is not dereferenceable when n_uniforms == 0).
   * Required (non-NULL). Pure, reentrant, deterministic (see CONTRACT). */
  double (*evaluate)(double n, double p, const double* u);
  /* Exact law of K, or NULL when there is none (then law.pmf raises NotImplementedError).
   * Writes P(K = first_k + i) (after binning) to probs[i] for i < the returned length, sets
   * *first_k, and may set bits GLINTLAB_TRIMMED_BELOW / _ABOVE in *trimmed (the loader sets
   * *trimmed = 0 before the call) when it dropped a negligible tail on that side: the chi-square
   * test then counts samples beyond that end in the end bin instead of failing outright.
   * Returns the length (1 .. capacity); GLINTLAB_PMF_CAPACITY (-1) if capacity is too small (the
   * loader retries with a larger buffer, up to the caller's max_support, then reports that the
   * law needs more points); GLINTLAB_PMF_NONE (-2) if there is no exact law at this (n, p)
   * (NotImplementedError naming (n, p)). Probabilities must be finite, >= 0, summing to 1
   * within 1e-9. Reentrant and deterministic like evaluate. */
  long long (*pmf)(double n, double p, double* probs, long long capacity, long long* first_k, int* trimmed);
} glintlab_law_v1;

/* The function a plugin exports (declared here so a definition is checked against it). */
GLINTLAB_PLUGIN_EXPORT const glintlab_law_v1* glintlab_plugin_laws_v1(int* count);

typedef const glintlab_law_v1* (*glintlab_plugin_laws_v1_fn)(int* count);

#ifdef __cplusplus
} /* extern "C" */
#endif

/* Defines the entry point from a list of glintlab_law_v1 initializers (C or C++):
 *     GLINTLAB_PLUGIN({"my_law", "summary", 1, "none", my_eval, NULL})                        (C)
 *     GLINTLAB_PLUGIN(glintlab::plugin::law("my_law", "summary", 1, my_eval),
 *                     glintlab::plugin::law("my_other", "summary", 2, other).with_pmf(pmf)) (C++)
 * The table is a function-local static, initialized at compile time (no static-init order
 * issues). */
#define GLINTLAB_PLUGIN(...)                                                                                   \
  GLINTLAB_PLUGIN_EXTERN_C GLINTLAB_PLUGIN_EXPORT const glintlab_law_v1* glintlab_plugin_laws_v1(int* count) { \
    static const glintlab_law_v1 glintlab_plugin_table_[] = {__VA_ARGS__};                                     \
    *count = (int)(sizeof glintlab_plugin_table_ / sizeof glintlab_plugin_table_[0]);                          \
    return glintlab_plugin_table_;                                                                             \
  }

#ifdef __cplusplus
namespace glintlab::plugin {

using evaluate_fn = double (*)(double n, double p, const double* u);
using pmf_fn = long long (*)(double n, double p, double* probs, long long capacity, long long* first_k, int* trimmed);

// A table entry built by name instead of by field order (C++17 has no designated initializers,
// and in C++20 they must follow the declaration order). Chain .with_pmf(f) and .with_binning("round").
struct law : glintlab_law_v1 {
  constexpr law(const char* name_, const char* summary_, int n_uniforms_, evaluate_fn evaluate_)
      : glintlab_law_v1{name_, summary_, n_uniforms_, "none", evaluate_, nullptr} {}
  constexpr law with_pmf(pmf_fn pmf_) const {
    law out = *this;
    out.pmf = pmf_;
    return out;
  }
  constexpr law with_binning(const char* binning_) const {
    law out = *this;
    out.binning = binning_;
    return out;
  }
};

}  // namespace glintlab::plugin
#endif

#endif /* GLINTLAB_PLUGIN_H */
