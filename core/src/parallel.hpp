// Private helper of the core's vectorized drivers: one place that splits a batch across OpenMP
// threads and carries the first exception back to the caller (an exception must not escape an
// OpenMP region), and stops between chunks on an interrupt request. Every item derives its random numbers from its own
// index, so results never depend on the split.
#pragma once

#include <algorithm>
#include <cstddef>
#include <exception>
#include <mutex>

#include "glintlab/errors.hpp"
#include "glintlab/law.hpp"

namespace glintlab::detail {

// Runs body(i0, i1) over [0, count) in chunks of `chunk` items, dynamically scheduled on
// num_threads() threads; below `serial_below` items everything runs on the calling thread
// (spawning would cost more than it saves).
template <class Body>
void parallel_chunks(std::size_t count, std::size_t chunk, std::size_t serial_below, Body body) {
  const int threads = count < serial_below ? 1 : num_threads();
  const std::size_t chunks = (count + chunk - 1) / chunk;
  std::exception_ptr error;
  std::mutex error_mutex;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t c = 0; c < chunks; ++c) {
    try {
      // Ctrl-C: checked once per chunk (microseconds of work), so a long batch stops promptly.
      if (interrupt_requested()) throw interrupted("interrupted");
      body(c * chunk, std::min(count, (c + 1) * chunk));
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace glintlab::detail
