/* A deliberately broken glintlab plugin, for the loader's tests. Written in C99 so that the build
 * also checks that glintlab/plugin.h compiles as C.
 *
 * GLINTLAB_BAD_PLUGIN_CASE (read at each load, so one library serves every case) selects a table
 * the loader must refuse: n_uniforms, empty_name, bad_name, null_name, null_evaluate, binning,
 * duplicate, clash, empty, null_table. Unset (or any other value) gives a table that loads but
 * whose callbacks misbehave at call time: pmfs with a bad sum, a negative or NaN probability, a
 * length beyond the capacity, no exact law, a support that needs a larger buffer; and an evaluate
 * returning NaN. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "glintlab/plugin.h"

static double zero(double n, double p, const double* u) {
  (void)n, (void)p, (void)u;
  return 0.0;
}

static double nan_eval(double n, double p, const double* u) {
  (void)n, (void)u;
  return p > 0.5 ? NAN : 0.0;
}

/* Two points with the given probabilities. */
static long long two_points(double* probs, long long capacity, long long* first_k, double a, double b) {
  if (capacity < 2) return GLINTLAB_PMF_CAPACITY;
  *first_k = 0;
  probs[0] = a;
  probs[1] = b;
  return 2;
}

static long long pmf_sum(double n, double p, double* probs, long long capacity, long long* first_k, int* trimmed) {
  (void)n, (void)p, (void)trimmed;
  return two_points(probs, capacity, first_k, 0.25, 0.25);
}

static long long pmf_negative(double n, double p, double* probs, long long capacity, long long* first_k,
                              int* trimmed) {
  (void)n, (void)p, (void)trimmed;
  return two_points(probs, capacity, first_k, 1.5, -0.5);
}

static long long pmf_nan(double n, double p, double* probs, long long capacity, long long* first_k, int* trimmed) {
  (void)n, (void)p, (void)trimmed;
  return two_points(probs, capacity, first_k, NAN, 1.0);
}

static long long pmf_overflow(double n, double p, double* probs, long long capacity, long long* first_k,
                              int* trimmed) {
  (void)n, (void)p, (void)probs, (void)first_k, (void)trimmed;
  return capacity + 1;
}

static long long pmf_none(double n, double p, double* probs, long long capacity, long long* first_k, int* trimmed) {
  (void)n, (void)p, (void)probs, (void)capacity, (void)first_k, (void)trimmed;
  return GLINTLAB_PMF_NONE;
}

/* Uniform on 0 .. 9999: needs a buffer of 10000 points (more than the loader's first try). */
static long long pmf_wide(double n, double p, double* probs, long long capacity, long long* first_k, int* trimmed) {
  long long i;
  (void)n, (void)p, (void)trimmed;
  if (capacity < 10000) return GLINTLAB_PMF_CAPACITY;
  *first_k = 0;
  for (i = 0; i < 10000; ++i) probs[i] = 1e-4;
  return 10000;
}

static const glintlab_law_v1 loads_but_misbehaves[] = {
    {"bad_pmf_sum", "pmf sums to 0.5", 0, "none", zero, pmf_sum},
    {"bad_pmf_negative", "pmf has a negative probability", 0, "none", zero, pmf_negative},
    {"bad_pmf_nan", "pmf has a NaN", 0, "none", zero, pmf_nan},
    {"bad_pmf_overflow", "pmf claims more points than fit", 0, "none", zero, pmf_overflow},
    {"bad_pmf_none", "pmf has no exact law anywhere", 0, "none", zero, pmf_none},
    {"bad_pmf_wide", "uniform on 0 .. 9999", 0, "none", zero, pmf_wide},
    {"bad_nan_eval", "evaluate returns NaN for p > 1/2", 1, NULL, nan_eval, NULL},
};

static const glintlab_law_v1 bad_n_uniforms[] = {{"bad_k", NULL, 9, "none", zero, NULL}};
static const glintlab_law_v1 empty_name[] = {{"", NULL, 1, "none", zero, NULL}};
static const glintlab_law_v1 bad_name[] = {{"has space", NULL, 1, "none", zero, NULL}};
static const glintlab_law_v1 null_name[] = {{NULL, NULL, 1, "none", zero, NULL}};
static const glintlab_law_v1 null_evaluate[] = {{"bad_eval", NULL, 1, "none", NULL, NULL}};
static const glintlab_law_v1 bad_binning[] = {{"bad_binning", NULL, 1, "floor", zero, NULL}};
static const glintlab_law_v1 duplicate[] = {{"bad_twice", NULL, 1, "none", zero, NULL},
                                            {"bad_twice", NULL, 1, "none", zero, NULL}};
static const glintlab_law_v1 clash[] = {{"bad_fine", NULL, 1, "none", zero, NULL},
                                        {"binomial", NULL, 1, "none", zero, NULL}};

#define TABLE(t) (*count = (int)(sizeof t / sizeof t[0]), t)

GLINTLAB_PLUGIN_EXPORT const glintlab_law_v1* glintlab_plugin_laws_v1(int* count) {
  const char* c = getenv("GLINTLAB_BAD_PLUGIN_CASE");
  if (!c) c = "";
  if (!strcmp(c, "n_uniforms")) return TABLE(bad_n_uniforms);
  if (!strcmp(c, "empty_name")) return TABLE(empty_name);
  if (!strcmp(c, "bad_name")) return TABLE(bad_name);
  if (!strcmp(c, "null_name")) return TABLE(null_name);
  if (!strcmp(c, "null_evaluate")) return TABLE(null_evaluate);
  if (!strcmp(c, "binning")) return TABLE(bad_binning);
  if (!strcmp(c, "duplicate")) return TABLE(duplicate);
  if (!strcmp(c, "clash")) return TABLE(clash);
  if (!strcmp(c, "empty")) {
    *count = 0;
    return loads_but_misbehaves;
  }
  if (!strcmp(c, "null_table")) {
    *count = 1;
    return NULL;
  }
  return TABLE(loads_but_misbehaves);
}
