// Private helper of the core's vectorized drivers: one place that splits a batch across OpenMP
// threads and carries the first exception back to the caller (an exception must not escape an
// OpenMP region), and stops between chunks on an interrupt request. Every item derives its random
// numbers from its own index, so results never depend on the split or the thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <exception>
#include <mutex>

#include "glintlab/base/errors.hpp"
#include "glintlab/base/threads.hpp"

namespace glintlab::detail {

// Runs body(i0, i1) over [0, count) in chunks of `chunk` items, dynamically scheduled on up to
// num_threads() threads, never more than there are chunks. Below `serial_below` items (or with one
// chunk, or one thread) everything runs on the calling thread and no parallel region opens: a
// region's end waits for every thread of its team, and on a machine shared with other jobs a worker
// can be descheduled for milliseconds, which a short batch must not pay
// (docs/guide/performance.md#threads-on-a-loaded-machine).
template <class Body>
void parallel_chunks(std::size_t count, std::size_t chunk, std::size_t serial_below, Body body) {
  const std::size_t chunks = (count + chunk - 1) / chunk;
  const std::size_t threads =
      count < serial_below ? 1 : std::min(chunks, static_cast<std::size_t>(std::max(num_threads(), 1)));
  if (threads <= 1) {
    for (std::size_t c = 0; c < chunks; ++c) {
      // Ctrl-C: checked once per chunk (microseconds of work), so a long batch stops promptly.
      if (interrupt_requested()) throw interrupted("interrupted");
      body(c * chunk, std::min(count, (c + 1) * chunk));
    }
    return;
  }
  std::exception_ptr error;
  std::mutex error_mutex;
#pragma omp parallel for schedule(dynamic, 1) num_threads(static_cast <int>(threads))
  for (std::size_t c = 0; c < chunks; ++c) {
    try {
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
