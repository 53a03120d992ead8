// Vulkan timestamp queries around the runner's dispatches (glintlab/validation/dispatch_timing.hpp). One
// query pool of two timestamps per device, made on first use and used with the device's mutex held
// (every submission holds it from recording to its fence), so one pool serves all the device's calls.
#include "glintlab/validation/dispatch_timing.hpp"

#include <map>
#include <mutex>
#include <string>

#include "dispatch_timing.hpp"

namespace glintlab::shader {
namespace {
thread_local DispatchTiming* t_current = nullptr;
}  // namespace

struct TimingSink {
  static DispatchTiming* current() { return t_current; }
  static void add(double ms) { t_current->ms_.push_back(ms); }
};

DispatchTiming::DispatchTiming() : outer_(t_current) { t_current = this; }
DispatchTiming::~DispatchTiming() { t_current = outer_; }

namespace detail {
namespace {

struct Queries {
  VkQueryPool pool = VK_NULL_HANDLE;
  double period_ns = 1.0;      // nanoseconds per tick (VkPhysicalDeviceLimits::timestampPeriod)
  std::uint64_t mask = ~0ull;  // the valid bits of a timestamp (the queue family's timestampValidBits)
};

std::mutex g_pools_mutex;  // the map only: each pool is used under its device's mutex

// The device's pool, made on first use and kept for the process's life as the device is.
Queries& queries(Device& d) {
  static std::map<const Device*, Queries> pools;
  std::lock_guard<std::mutex> lock(g_pools_mutex);
  Queries& q = pools[&d];
  if (q.pool) return q;
  std::uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(d.phys, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(d.phys, &n, families.data());
  const std::uint32_t bits = d.family < n ? families[d.family].timestampValidBits : 0;
  if (bits == 0)
    throw NoTimestamps("Vulkan device '" + d.name + "' records no timestamps on its compute queue (queue family " +
                       std::to_string(d.family) + ": timestampValidBits = 0): it cannot time dispatches");
  VkPhysicalDeviceProperties props{};
  vkGetPhysicalDeviceProperties(d.phys, &props);
  q.period_ns = static_cast<double>(props.limits.timestampPeriod);
  q.mask = bits >= 64 ? ~0ull : (std::uint64_t{1} << bits) - 1;
  VkQueryPoolCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = 2;
  check(vkCreateQueryPool(d.dev, &info, nullptr, &q.pool), "vkCreateQueryPool");
  return q;
}

}  // namespace

bool timestamp_before(Device& d, VkCommandBuffer command) {
  if (!TimingSink::current()) return false;
  const Queries& q = queries(d);
  vkCmdResetQueryPool(command, q.pool, 0, 2);
  // Top of the pipe: once the commands before have started, not finished; the barrier-free start of the
  // dispatch is what a GPU profiler's "begin" marks.
  vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, q.pool, 0);
  return true;
}

void timestamp_after(Device& d, VkCommandBuffer command) {
  if (!TimingSink::current()) return;
  // Bottom of the pipe: once every invocation of the dispatch has finished.
  vkCmdWriteTimestamp(command, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries(d).pool, 1);
}

void timestamp_read(Device& d) {
  if (!TimingSink::current()) return;
  const Queries& q = queries(d);
  std::uint64_t stamps[2] = {0, 0};
  check(vkGetQueryPoolResults(d.dev, q.pool, 0, 2, sizeof(stamps), stamps, sizeof(std::uint64_t),
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults");
  // Modulo the valid bits: a counter that wrapped between the two still gives the right difference.
  const std::uint64_t ticks = (stamps[1] - stamps[0]) & q.mask;
  TimingSink::add(static_cast<double>(ticks) * q.period_ns * 1e-6);
}

}  // namespace detail
}  // namespace glintlab::shader
