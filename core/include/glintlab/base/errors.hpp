// Parameter validation in one place, with one message format (Boost.Math's lesson): every entry
// point reports "<where>: <name> = <value> is invalid; expected <what>" as std::invalid_argument,
// which the Python layer surfaces as ValueError. Two more shapes of bad input have one message each:
// an array of the wrong length (check_length) and a name outside an enum's table (parse_enum).
// Nothing in core/, validation/ or bindings/ throws std::invalid_argument itself
// (tests/python/test_error_vocabulary.py keeps it so).
#pragma once

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace glintlab {

// Raised by laws that have no exact distribution (Python: NotImplementedError).
class not_implemented : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

// Raised by long loops once an interrupt was requested (Python: KeyboardInterrupt).
class interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Ctrl-C for C++ loops that run without the GIL: the Python layer's SIGINT handler calls
// request_interrupt() (a lock-free atomic store, safe in a signal handler); every batch driver checks
// interrupt_requested() between chunks of work and throws `interrupted`.
void request_interrupt() noexcept;
void clear_interrupt() noexcept;
bool interrupt_requested() noexcept;

std::string format_value(double value);

[[noreturn]] void throw_invalid(std::string_view where, std::string_view name, double value, std::string_view expected);
[[noreturn]] void throw_invalid(std::string_view where, std::string_view name, std::string_view value,
                                std::string_view expected);

// A message of its own, for the few checks that fit none of the shapes here (a document's
// structure, a plugin that does not load): std::invalid_argument(message).
[[noreturn]] void throw_invalid_message(std::string message);

// A per-row argument `name` of `size` values broadcast against `count` rows: one value for all
// rows or one per row, else "<where>: <name> has <size> values; expected 1 or <count>".
void check_length(std::string_view where, std::string_view name, std::size_t size, std::size_t count);

// "<where>: unknown <what> '<name>'; known: a, b, c" (the registries' message, registry.hpp).
[[noreturn]] void throw_unknown_name(std::string_view where, std::string_view what, std::string_view name,
                                     std::string_view known);

// An enum's names in one table (any range of {name, value} pairs, in the order the message lists
// them): parse_enum reads a name, refusing an unknown one with the message above; enum_name writes
// one ("?" for a value not in the table).
template <class Table>
auto parse_enum(std::string_view where, std::string_view what, std::string_view name, const Table& table) {
  std::string known;
  for (const auto& [text, value] : table) {
    if (std::string_view(text) == name) return value;
    known.append(known.empty() ? "" : ", ").append(text);
  }
  throw_unknown_name(where, what, name, known);
}
template <class Table, class E>
std::string enum_name(E value, const Table& table) {
  for (const auto& [text, v] : table)
    if (v == value) return std::string(text);
  return "?";
}

// "n" or "n[12]" for array arguments, so a bad element can be found.
std::string indexed_name(std::string_view name, std::size_t index, bool is_array);

// Facet count n: finite and >= 0 (non-integer allowed; each law states its rule for it).
inline void check_n(std::string_view where, double n, std::string_view name = "n") {
  if (!(n >= 0.0) || !std::isfinite(n)) throw_invalid(where, name, n, "a finite number >= 0");
}
// Probability p in [0, 1].
inline void check_p(std::string_view where, double p, std::string_view name = "p") {
  if (!(p >= 0.0 && p <= 1.0)) throw_invalid(where, name, p, "a probability in [0, 1]");
}
// A uniform random number in [0, 1].
inline void check_u(std::string_view where, double u, std::string_view name = "u") {
  if (!(u >= 0.0 && u <= 1.0)) throw_invalid(where, name, u, "a uniform number in [0, 1]");
}

}  // namespace glintlab
