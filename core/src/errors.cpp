#include "glintlab/errors.hpp"

#include <atomic>
#include <cstdio>

namespace glintlab {

namespace {
std::atomic<bool> g_interrupt{false};
static_assert(std::atomic<bool>::is_always_lock_free, "request_interrupt runs in a signal handler");
}  // namespace

void request_interrupt() noexcept { g_interrupt.store(true, std::memory_order_relaxed); }
void clear_interrupt() noexcept { g_interrupt.store(false, std::memory_order_relaxed); }
bool interrupt_requested() noexcept { return g_interrupt.load(std::memory_order_relaxed); }

std::string format_value(double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", value);
  return buf;
}

void throw_invalid(std::string_view where, std::string_view name, double value,
                   std::string_view expected) {
  throw_invalid(where, name, format_value(value), expected);
}

void throw_invalid(std::string_view where, std::string_view name, std::string_view value,
                   std::string_view expected) {
  std::string msg;
  msg.append(where).append(": ").append(name).append(" = ").append(value);
  msg.append(" is invalid; expected ").append(expected);
  throw std::invalid_argument(msg);
}

std::string indexed_name(std::string_view name, std::size_t index, bool is_array) {
  std::string s(name);
  if (is_array) s.append("[").append(std::to_string(index)).append("]");
  return s;
}

}  // namespace glintlab
