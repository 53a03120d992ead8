// Parameter validation in one place, with one message format (Boost.Math's lesson): every entry
// point reports "<where>: <name> = <value> is invalid; expected <what>" as std::invalid_argument,
// which the Python layer surfaces as ValueError.
#pragma once

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

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

[[noreturn]] void throw_invalid(std::string_view where, std::string_view name, double value,
                                std::string_view expected);
[[noreturn]] void throw_invalid(std::string_view where, std::string_view name,
                                std::string_view value, std::string_view expected);

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
