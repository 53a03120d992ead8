#include "glintlab/base/threads.hpp"

#include <omp.h>

#include <cstdlib>

#include "glintlab/base/errors.hpp"

namespace glintlab {

namespace {

int& thread_setting() {
  static int threads = [] {
    if (const char* env = std::getenv("GLINTLAB_NUM_THREADS")) {
      const int t = std::atoi(env);
      if (t > 0) return t;
    }
    return omp_get_num_procs();
  }();
  return threads;
}

}  // namespace

void set_num_threads(int threads) {
  if (threads < 1) throw_invalid("set_num_threads", "threads", threads, "an integer >= 1");
  thread_setting() = threads;
}

int num_threads() { return thread_setting(); }

}  // namespace glintlab
