#include "glintlab/stats/normal.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "glintlab/base/errors.hpp"

namespace glintlab::normal {

LatticeLaw discretized(double mean, double sd, double top, double shift, std::size_t max_support, const char* where) {
  // K = k iff k - shift <= G < k + 1 - shift, with the ends taking the clamped tails.
  const double lo = std::clamp(std::floor(mean + shift - 8.5 * sd), 0.0, top);
  const double hi = std::clamp(std::ceil(mean + shift + 8.5 * sd), 0.0, top);
  // Beyond 2^53 doubles are no longer spaced by 1: k += 1 would not advance (and lo == hi could pass
  // the size check below), so the support loop would never end. Refuse such a lattice by name.
  if (hi >= 0x1p53)
    throw_invalid_message(std::string(where) + ": mean = " + format_value(mean) + ", sd = " + format_value(sd) +
                          " puts the support at counts above 2^53 (9.007e15), where "
                          "doubles no longer hold consecutive integers; expected a mean below 9e15");
  if (hi - lo + 1 > static_cast<double>(max_support))
    throw_invalid_message(std::string(where) + ": mean = " + format_value(mean) + ", sd = " + format_value(sd) +
                          " needs more than max_support = " + std::to_string(max_support) + " support points");
  LatticeLaw out;
  for (double k = lo; k <= hi; k += 1) {
    const double a = k == 0 ? -INFINITY : (k - shift - mean) / sd;
    const double b = k == top ? INFINITY : (k + 1 - shift - mean) / sd;
    out.support.push_back(k);
    out.probs.push_back(interval(a, b));
  }
  out.trimmed_below = lo > 0;
  out.trimmed_above = hi < top;
  return out;
}

}  // namespace glintlab::normal
