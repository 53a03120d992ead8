// Device timings of the shader runner's dispatches (docs/guide/gpu_cost.md, "Timings on a device"):
// while a DispatchTiming lives, every kernel dispatch its thread submits (a law's, a method shader's or a
// sampler's; one per chunk of rows) is bracketed by two Vulkan timestamps, and the difference, in the
// device's clock (timestampPeriod nanoseconds per tick, timestampValidBits wide), is appended in
// milliseconds. The upload before and the read-back after a dispatch are outside the brackets.
//
// What a timing means is the device's: on a GPU, the kernel's time on the GPU; on lavapipe (a CPU Vulkan
// device) the time its CPU threads took to run the dispatch.
#pragma once

#include <stdexcept>
#include <vector>

namespace glintlab::shader {

// The device records no timestamps on its compute queue (timestampValidBits = 0) (Python: RuntimeError).
class NoTimestamps : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class DispatchTiming {
 public:
  DispatchTiming();  // this thread's dispatches are timed from now (scopes nest: the innermost records)
  ~DispatchTiming();
  DispatchTiming(const DispatchTiming&) = delete;
  DispatchTiming& operator=(const DispatchTiming&) = delete;
  // One entry per dispatch, in submission order.
  const std::vector<double>& milliseconds() const { return ms_; }

 private:
  friend struct TimingSink;
  std::vector<double> ms_;
  DispatchTiming* outer_;
};

}  // namespace glintlab::shader
