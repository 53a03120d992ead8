// glintlab/base/float16.hpp: the portable half-float rounding of the "gated_shader" law, checked bit for bit
// against the compiler's _Float16 conversion where it has one (GCC on x86-64), and against values
// worked out by hand everywhere (Clang 14 has no _Float16 on x86-64).
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>

#include "glintlab/base/float16.hpp"

namespace {

std::uint32_t bits_of(float x) {
  std::uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

float float_of(std::uint32_t b) {
  float x;
  std::memcpy(&x, &b, sizeof x);
  return x;
}

#ifdef __FLT16_MANT_DIG__
std::uint16_t reference_half_bits(float x) {
  const _Float16 h = static_cast<_Float16>(x);
  std::uint16_t b;
  std::memcpy(&b, &h, sizeof b);
  return b;
}

float reference_half_float(std::uint16_t b) {
  _Float16 h;
  std::memcpy(&h, &b, sizeof h);
  return static_cast<float>(h);
}

// Counts the float bit patterns f = hi..., visited by `next`, whose conversion differs from _Float16's.
template <class Next>
std::uint64_t mismatches(std::uint64_t first, std::uint64_t last, Next next, std::uint32_t& first_bad) {
  std::uint64_t bad = 0;
  for (std::uint64_t f = first; f <= last; f = next(f)) {
    const float x = float_of(static_cast<std::uint32_t>(f));
    if (glintlab::float_to_half_bits(x) != reference_half_bits(x) ||
        bits_of(glintlab::round_to_half(x)) != bits_of(reference_half_float(reference_half_bits(x)))) {
      if (bad++ == 0) first_bad = static_cast<std::uint32_t>(f);
    }
  }
  return bad;
}
#endif

}  // namespace

TEST_CASE("float16: hand-worked values round to nearest even", "[float16]") {
  using glintlab::float_to_half_bits;
  using glintlab::round_to_half;
  CHECK(float_to_half_bits(0.0f) == 0x0000u);
  CHECK(float_to_half_bits(-0.0f) == 0x8000u);
  CHECK(float_to_half_bits(1.0f) == 0x3C00u);
  CHECK(float_to_half_bits(-2.0f) == 0xC000u);
  CHECK(float_to_half_bits(65504.0f) == 0x7BFFu);    // the largest half
  CHECK(float_to_half_bits(65519.996f) == 0x7BFFu);  // just below the midpoint
  CHECK(float_to_half_bits(65520.0f) == 0x7C00u);    // the midpoint: ties to even = infinity
  CHECK(float_to_half_bits(1e30f) == 0x7C00u);
  CHECK(float_to_half_bits(-__builtin_inff()) == 0xFC00u);
  CHECK((float_to_half_bits(__builtin_nanf("")) & 0x7E00u) == 0x7E00u);  // NaN stays a quiet NaN
  CHECK(float_to_half_bits(float_of(0x7F800001u)) == 0x7E00u);           // a signalling NaN is quieted
  // 1 + 2^-11 is the midpoint between 1 and 1 + 2^-10: ties to even gives 1; 1 + 3 2^-11 gives 1 + 2^-9.
  CHECK(float_to_half_bits(1.0f + 0x1p-11f) == 0x3C00u);
  CHECK(float_to_half_bits(1.0f + 3 * 0x1p-11f) == 0x3C02u);
  CHECK(float_to_half_bits(1.0f + 0x1p-11f + 0x1p-23f) == 0x3C01u);  // above the midpoint
  // Subnormals: multiples of 2^-24; 2^-25 ties to 0, just above it rounds to 2^-24.
  CHECK(float_to_half_bits(0x1p-24f) == 0x0001u);
  CHECK(float_to_half_bits(0x1p-25f) == 0x0000u);
  CHECK(float_to_half_bits(float_of(bits_of(0x1p-25f) + 1)) == 0x0001u);
  CHECK(float_to_half_bits(3 * 0x1p-25f) == 0x0002u);         // 1.5 2^-24: tie to even 2
  CHECK(float_to_half_bits(5 * 0x1p-25f) == 0x0002u);         // 2.5 2^-24: tie to even 2
  CHECK(float_to_half_bits(0x1p-14f - 0x1p-26f) == 0x0400u);  // rounds up into the normals
  CHECK(float_to_half_bits(0x1p-14f) == 0x0400u);
  CHECK(round_to_half(1e-30f) == 0.0f);
  CHECK(round_to_half(0.1f) == 0.0999755859375f);
  // Every half value converts back and forth unchanged (NaNs stay NaN).
  for (std::uint32_t h = 0; h <= 0xFFFFu; ++h) {
    const float x = glintlab::half_bits_to_float(static_cast<std::uint16_t>(h));
    if (x != x) {
      CHECK((glintlab::float_to_half_bits(x) & 0x7C00u) == 0x7C00u);
    } else if (glintlab::float_to_half_bits(x) != h) {
      FAIL("half 0x" << std::hex << h << " -> " << x << " -> 0x" << glintlab::float_to_half_bits(x));
    }
  }
}

#ifdef __FLT16_MANT_DIG__
TEST_CASE("float16: bit-identical to _Float16 on every half and on the rounding boundaries", "[float16]") {
  for (std::uint32_t h = 0; h <= 0xFFFFu; ++h) {
    const auto b = static_cast<std::uint16_t>(h);
    if (bits_of(glintlab::half_bits_to_float(b)) != bits_of(reference_half_float(b)))
      FAIL("half 0x" << std::hex << h << ": 0x" << bits_of(glintlab::half_bits_to_float(b)) << " vs _Float16's 0x"
                     << bits_of(reference_half_float(b)));
  }
  // Every float whose 13 lowest bits are near a rounding boundary of the normal halves (0, 1, the
  // midpoint 0x1000 and its neighbours, 0x1FFF), for all 2^19 upper parts: 2^22 floats. Then every
  // 61st float in the subnormal halves' range [2^-25, 2^-14) (both signs), where the rounding position
  // moves, and every 4099th float of all 2^32.
  std::uint32_t first_bad = 0;
  std::uint64_t bad = 0;
  const std::uint32_t lows[] = {0x0000u, 0x0001u, 0x0800u, 0x0FFFu, 0x1000u, 0x1001u, 0x1800u, 0x1FFFu};
  for (std::uint32_t hi = 0; hi < (1u << 19); ++hi)
    for (const std::uint32_t lo : lows) {
      const std::uint32_t f = (hi << 13) | lo;
      bad += mismatches(
          f, f, [](std::uint64_t g) { return g + 1; }, first_bad);
    }
  for (const std::uint64_t s : {0x00000000ull, 0x80000000ull})
    bad += mismatches(
        s | 0x33000000ull, s | 0x38800000ull, [](std::uint64_t g) { return g + 61; }, first_bad);
  bad += mismatches(
      0, 0xFFFFFFFFull, [](std::uint64_t g) { return g + 4099; }, first_bad);
  INFO("first mismatch: float bits 0x" << std::hex << first_bad);
  CHECK(bad == 0);
}

// All 2^32 floats (about a minute on one core): `glintlab_tests "[float16-exhaustive]"`.
TEST_CASE("float16: bit-identical to _Float16 on all 2^32 floats", "[.][float16-exhaustive]") {
  std::uint32_t first_bad = 0;
  const std::uint64_t bad = mismatches(
      0, 0xFFFFFFFFull, [](std::uint64_t g) { return g + 1; }, first_bad);
  INFO("first mismatch: float bits 0x" << std::hex << first_bad);
  CHECK(bad == 0);
}
#endif
