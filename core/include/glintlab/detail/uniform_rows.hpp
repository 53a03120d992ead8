// The vectorized uniforms of the drivers and the kernels' instruction-set switch: internal to the
// library (the laws' fast paths, the blends, the tests that pin every SIMD level to the same bits).
#pragma once

#include <cstddef>
#include <cstdint>

namespace glintlab::detail {

// The highest instruction set the vector kernels may use: 2 AVX-512, 1 AVX2, 0 portable
// (default 2; the CPU caps it too). Every level gives the same bits: tests lower it to check so.
void set_simd_level(int level);
int simd_level();  // the level in effect: min(the setting, what the CPU has)

// Rows [start, start + count) of fill_uniforms (bit-identical at every SIMD level).
void philox_uniform_rows(std::uint64_t seed, std::uint16_t stream, std::size_t start, std::size_t count, int k,
                         double* out);
// The same rows at LOD level `level` (16-bit key): row r holds the first k draws of
// CounterRng(seed, low 32 bits of r, high 32 bits of r, level, stream).
void philox_uniform_rows_level(std::uint64_t seed, std::uint16_t level, std::uint16_t stream, std::size_t start,
                               std::size_t count, int k, double* out);

}  // namespace glintlab::detail
