// Private helper of the core: splitmix64's finalizer (Steele, Lea & Flood 2014), the hash that keys
// per-cell random numbers (grid realizations, facet positions) by cell index and seed, so that a
// cell's numbers never depend on the order or the thread it is visited in.
#pragma once

#include <cstdint>

namespace glintlab::detail {

inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

}  // namespace glintlab::detail
