// The shader runner's side of DispatchTiming (glintlab/validation/dispatch_timing.hpp): the submit path
// (shader_runner.cpp) calls these around each dispatch, with the device's mutex held. Each is a no-op
// when the calling thread times nothing.
#pragma once

#include <vulkan/vulkan.h>

#include "vulkan_device.hpp"

namespace glintlab::shader::detail {

// Before the dispatch: resets the device's two queries and writes the first timestamp. Returns whether
// this thread is timing. Throws NoTimestamps for a device whose compute queue has none.
bool timestamp_before(Device& d, VkCommandBuffer command);
// After the dispatch, in the same command buffer: the second timestamp.
void timestamp_after(Device& d, VkCommandBuffer command);
// After the submission's fence: the two timestamps read back, their difference appended to this thread's
// DispatchTiming.
void timestamp_read(Device& d);

}  // namespace glintlab::shader::detail
