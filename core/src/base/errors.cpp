#include "glintlab/base/errors.hpp"

#include <atomic>
#include <cstdio>
#include <utility>

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

void throw_invalid(std::string_view where, std::string_view name, double value, std::string_view expected) {
  throw_invalid(where, name, format_value(value), expected);
}

void throw_invalid(std::string_view where, std::string_view name, std::string_view value, std::string_view expected) {
  std::string msg;
  if (!where.empty()) msg.append(where).append(": ");  // no context: the message starts at the name
  msg.append(name).append(" = ").append(value);
  msg.append(" is invalid; expected ").append(expected);
  throw std::invalid_argument(msg);
}

void throw_invalid_message(std::string message) { throw std::invalid_argument(std::move(message)); }

void check_length(std::string_view where, std::string_view name, std::size_t size, std::size_t count) {
  if (size == 1 || size == count) return;
  std::string msg;
  if (!where.empty()) msg.append(where).append(": ");
  msg.append(name).append(" has ").append(std::to_string(size)).append(" values; expected 1 or ");
  throw std::invalid_argument(msg.append(std::to_string(count)));
}

void throw_unknown_name(std::string_view where, std::string_view what, std::string_view name, std::string_view known) {
  std::string msg;
  if (!where.empty()) msg.append(where).append(": ");
  msg.append("unknown ").append(what).append(" '").append(name).append("'; known: ");
  throw std::invalid_argument(msg.append(known.empty() ? "(none)" : known));
}

std::string indexed_name(std::string_view name, std::size_t index, bool is_array) {
  std::string s(name);
  if (is_array) s.append("[").append(std::to_string(index)).append("]");
  return s;
}

}  // namespace glintlab
