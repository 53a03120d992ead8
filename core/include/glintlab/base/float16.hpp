// IEEE 754 binary16 ("half") conversions without a compiler's _Float16, so the core builds with any
// C++20 compiler (GCC has _Float16 on x86-64; Clang 14 does not).
//
// float_to_half_bits rounds to nearest, ties to even, as a hardware or libgcc conversion does:
//   |x| >= 65520 (the midpoint between 65504, the largest half, and 2^16) -> infinity (the tie goes
//   to the even neighbour, which is the overflow); |x| <= 2^-25 -> signed zero (2^-25 is the tie
//   between 0 and the smallest subnormal 2^-24, and 0 is even); in between, subnormal halves are
//   multiples of 2^-24 and normal ones keep 10 fraction bits. NaN stays NaN: the top 10 payload bits
//   are kept and the quiet bit set. round_to_half(x) = half_bits_to_float(float_to_half_bits(x)) is
//   what a shader's `half(x)` stores; tests/cpp/test_float16.cpp compares it bit for bit with
//   _Float16 where the compiler has it.
#pragma once

#include <cstdint>
#include <cstring>

namespace glintlab {

inline std::uint16_t float_to_half_bits(float x) {
  std::uint32_t f;
  std::memcpy(&f, &x, sizeof f);
  const auto sign = static_cast<std::uint16_t>((f >> 16) & 0x8000u);
  const std::uint32_t a = f & 0x7FFFFFFFu;
  if (a >= 0x7F800000u)  // infinity, or NaN (quieted, top payload bits kept)
    return static_cast<std::uint16_t>(sign | (a == 0x7F800000u ? 0x7C00u : 0x7E00u | ((a >> 13) & 0x3FFu)));
  if (a >= 0x477FF000u) return static_cast<std::uint16_t>(sign | 0x7C00u);  // rounds to infinity
  if (a >= 0x38800000u) {                                                   // a normal half (|x| >= 2^-14)
    // Ties to even on the 13 dropped bits: adding 0xFFF plus the kept lowest bit carries exactly when
    // the dropped part is above one half, or is one half and the kept part is odd. A carry into the
    // exponent is the right result (1.11..1 rounds up to the next power of two).
    const std::uint32_t r = a + 0xFFFu + ((a >> 13) & 1u) - 0x38000000u;  // rebias 127 -> 15
    return static_cast<std::uint16_t>(sign | (r >> 13));
  }
  if (a <= 0x33000000u) return sign;  // |x| <= 2^-25: zero
  // A subnormal half: q 2^-24 with q = round(x / 2^-24). x = m 2^(e - 150) with the implicit bit in m,
  // so x / 2^-24 = m 2^-(126 - e), and 126 - e is in [14, 24] here.
  const std::uint32_t e = a >> 23, m = (a & 0x7FFFFFu) | 0x800000u, shift = 126u - e;
  std::uint32_t q = m >> shift;
  const std::uint32_t rem = m & ((1u << shift) - 1u), halfway = 1u << (shift - 1u);
  if (rem > halfway || (rem == halfway && (q & 1u))) ++q;  // q = 0x400 is the smallest normal: still right
  return static_cast<std::uint16_t>(sign | q);
}

inline float half_bits_to_float(std::uint16_t h) {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t e = (h >> 10) & 0x1Fu, m = h & 0x3FFu;
  std::uint32_t f;
  if (e == 0x1Fu) {
    f = sign | 0x7F800000u | (m << 13) | (m ? 0x400000u : 0u);  // infinity, or NaN (quieted)
  } else if (e != 0) {
    f = sign | ((e + 112u) << 23) | (m << 13);
  } else if (m == 0) {
    f = sign;
  } else {  // subnormal m 2^-24: normalise the fraction (m < 2^10, so 1 to 10 shifts)
    int k = 0;
    std::uint32_t mm = m;
    while (!(mm & 0x400u)) {
      mm <<= 1;
      ++k;
    }
    f = sign | ((113u - static_cast<std::uint32_t>(k)) << 23) | ((mm & 0x3FFu) << 13);
  }
  float x;
  std::memcpy(&x, &f, sizeof x);
  return x;
}

// x rounded to the nearest half-precision value (ties to even), as a float.
inline float round_to_half(float x) { return half_bits_to_float(float_to_half_bits(x)); }

}  // namespace glintlab
