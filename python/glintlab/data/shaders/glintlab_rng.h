// The core's counter-based random numbers in HLSL and GLSL, bit for bit (docs/math/glint_images.md#glint-db23-shader):
// 64-bit words emulated as uint2(low, high) on 32-bit integers (no 64-bit shader integers needed),
// splitmix64's finalizer (the core's mix64, which keys the anisotropic grids' cells), Philox4x32-10
// (the core's CounterRng, which keys KPT25's points), and the core's conversions of their outputs to
// uniforms, rounded to float32 exactly as the core's double uniforms convert. Written in the subset of
// glintlab_method_prelude.h; method bodies include it.
#ifndef GLINTLAB_RNG_H
#define GLINTLAB_RNG_H

uint2 glintlab_u64_add(uint2 a, uint2 b) {
  uint lo = a.x + b.x;
  return uint2(lo, a.y + b.y + (lo < a.x ? 1u : 0u));
}
uint2 glintlab_u64_mul(uint2 a, uint2 b) {  // the low 64 bits of a b
  uint hi, lo;
  GLINTLAB_MUL32(a.x, b.x, hi, lo);
  return uint2(lo, hi + a.x * b.y + a.y * b.x);
}
uint2 glintlab_u64_shr(uint2 a, int s) {  // 0 < s < 32
  return uint2((a.x >> uint(s)) | (a.y << uint(32 - s)), a.y >> uint(s));
}
uint2 glintlab_u64_from_int(int v) { return uint2(uint(v), v < 0 ? 0xFFFFFFFFu : 0u); }  // sign extension, as int64 -> uint64

// splitmix64's finalizer (the core's mix64: golden-ratio increment, two multiply-xorshifts).
uint2 glintlab_mix64(uint2 x) {
  x = glintlab_u64_add(x, uint2(0x7F4A7C15u, 0x9E3779B9u));
  x = glintlab_u64_mul(x ^ glintlab_u64_shr(x, 30), uint2(0x1CE4E5B9u, 0xBF58476Du));
  x = glintlab_u64_mul(x ^ glintlab_u64_shr(x, 27), uint2(0x133111EBu, 0x94D049BBu));
  return x ^ glintlab_u64_shr(x, 31);
}
uint2 glintlab_hash_combine(uint2 h, uint2 v) { return glintlab_mix64(h ^ glintlab_mix64(v)); }

// float(v 2^e), correctly rounded, for v < 2^63: the leading 32 bits with a sticky bit for the rest
// (the round bit is then bit 7 or above, so the sticky bit cannot change a tie's side).
float glintlab_float_u64(uint2 v, int e) {
  if (v.y == 0u) return GLINTLAB_LDEXP(float(v.x), e);
  int s = GLINTLAB_MSB(v.y) + 1;  // bits to drop: the word keeps 32 bits
  uint w = s == 32 ? v.y : ((v.x >> uint(s)) | (v.y << uint(32 - s)));
  uint dropped = s == 32 ? v.x : (v.x & ((1u << uint(s)) - 1u));
  if (dropped != 0u) w |= 1u;
  return GLINTLAB_LDEXP(float(w), e + s);
}

// The core's cell uniform (x >> 11 + 0.5) 2^-53, as float32 after the double rounding the core does:
// below 1/2 the double is exact ((2m + 1) 2^-54); from 1/2 on, m + 1/2 ties to the even neighbour.
float glintlab_unit53(uint2 x) {
  uint2 m = glintlab_u64_shr(x, 11);
  if ((x.y & 0x80000000u) == 0u) return glintlab_float_u64(glintlab_u64_shr(x, 10) | uint2(1u, 0u), -54);
  return glintlab_float_u64(glintlab_u64_add(m, uint2(m.x & 1u, 0u)), -53);
}

// Philox4x32-10 (Salmon et al. 2011): ten rounds of two 32 x 32 -> 64-bit products, the key bumped by
// the Weyl constants before every round but the first (the core's CounterRng::block).
uint4 glintlab_philox(uint4 c, uint2 k) {
  for (int r = 0; r < 10; ++r) {
    if (r > 0) k += uint2(0x9E3779B9u, 0xBB67AE85u);
    uint hi0, lo0, hi1, lo1;
    GLINTLAB_MUL32(0xD2511F53u, c.x, hi0, lo0);
    GLINTLAB_MUL32(0xCD9E8D57u, c.z, hi1, lo1);
    c = uint4(hi1 ^ c.y ^ k.x, lo1, hi0 ^ c.w ^ k.y, lo0);
  }
  return c;
}

// The core's (w + 1/2) 2^-32 of a 32-bit word, as float32: (2 w + 1) 2^-33 correctly rounded.
float glintlab_unit32(uint w) { return glintlab_float_u64(uint2(2u * w + 1u, w >> 31u), -33); }

#endif
