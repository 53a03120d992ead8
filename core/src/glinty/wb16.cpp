// WB16's Code 2 in float32 (core/include/glintlab/glinty/wb16.hpp). Built with -ffp-contract=off (CMakeLists.txt):
// every product and sum rounds to float32 on its own, as the shader's twin requires; the shader's driver
// may fuse some of them, which is part of the float32 allowance of the comparison
// (docs/math/glint_images.md#glint-wb16). Transcendentals are the C library's float32 log2f, powf and
// sqrtf (sqrt correctly rounded; log2 and pow within an ulp of a GPU's).
#include "glintlab/glinty/wb16.hpp"

#include <cmath>
#include <cstring>
#include <string>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"

namespace glintlab::wb16 {
namespace {

struct F3 {
  float x, y, z;
};

F3 operator+(F3 a, F3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
F3 operator-(F3 a, F3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
F3 operator*(float s, F3 a) { return {s * a.x, s * a.y, s * a.z}; }
F3 operator/(F3 a, float s) { return {a.x / s, a.y / s, a.z / s}; }
F3 add(F3 a, float s) { return {a.x + s, a.y + s, a.z + s}; }
// Left to right, as the shader's dot and the numpy twin's sum of products.
float dot(F3 a, F3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
F3 floor3(F3 a) { return {std::floor(a.x), std::floor(a.y), std::floor(a.z)}; }
// GLSL fract / HLSL frac: x - floor(x).
F3 fract3(F3 a) { return a - floor3(a); }
F3 abs3(F3 a) { return {std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)}; }
float sign1(float x) { return x > 0.0f ? 1.0f : x < 0.0f ? -1.0f : x; }  // 0 stays 0, NaN stays NaN
F3 sign3(F3 a) { return {sign1(a.x), sign1(a.y), sign1(a.z)}; }
F3 mul(F3 a, F3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }

float word_float(const std::uint32_t* row, int k) {
  float f;
  std::memcpy(&f, row + k, sizeof f);
  return f;
}
F3 word_f3(const std::uint32_t* row, int k) {
  return {word_float(row, k), word_float(row, k + 1), word_float(row, k + 2)};
}

// glintlab_hash3 on 32-bit words (wrapping arithmetic, as the shader's uint).
void hash3(std::uint32_t v[3]) {
  for (int j = 0; j < 3; ++j) v[j] = v[j] * 1664525u + 1013904223u;
  v[0] += v[1] * v[2];
  v[1] += v[2] * v[0];
  v[2] += v[0] * v[1];
  for (int j = 0; j < 3; ++j) v[j] ^= v[j] >> 16u;
  v[0] += v[1] * v[2];
  v[1] += v[2] * v[0];
  v[2] += v[0] * v[1];
}

// int(i) of the texture lookup. The shader's int conversion of a value outside int's range (or NaN)
// is undefined, and the value that follows is NaN or meaningless anyway; the numpy twin's int64 cast
// gives INT64_MIN there, kept so that the two twins agree bit for bit.
std::int64_t cell_index(float i) {
  return (std::isfinite(i) && std::fabs(i) < 9.0e18f) ? static_cast<std::int64_t>(i) : INT64_MIN;
}

}  // namespace

void cell_values(std::int64_t cx, std::int64_t cy, std::int64_t cz, std::uint32_t seed, float out[3]) {
  std::uint32_t k[3] = {static_cast<std::uint32_t>(cx) ^ (0x9E3779B9u * seed),
                        static_cast<std::uint32_t>(cy) ^ (0x85EBCA6Bu * seed),
                        static_cast<std::uint32_t>(cz) ^ (0xC2B2AE35u * seed)};
  hash3(k);
  // 24 bits each: exact in float32, times 2^-24 exact too.
  for (int j = 0; j < 3; ++j) out[j] = static_cast<float>(k[j] >> 8u) * (1.0f / 16777216.0f);
}

void noise3(const float p[3], std::uint32_t seed, float out[3]) {
  float f[3];
  std::int64_t c[3];
  for (int j = 0; j < 3; ++j) {
    const float x = p[j] * 128.0f - 0.5f;
    const float i = std::floor(x);
    f[j] = x - i;
    c[j] = cell_index(i);
  }
  // (c + d) & 127 in wrapping 64-bit arithmetic: the texture's wrap addressing.
  auto wrap = [](std::int64_t a, int d) {
    return static_cast<std::int64_t>((static_cast<std::uint64_t>(a) + static_cast<std::uint64_t>(d)) & 127u);
  };
  float v[2][2][2][3];
  for (int dx = 0; dx < 2; ++dx)
    for (int dy = 0; dy < 2; ++dy)
      for (int dz = 0; dz < 2; ++dz) cell_values(wrap(c[0], dx), wrap(c[1], dy), wrap(c[2], dz), seed, v[dx][dy][dz]);
  // Linear in x, then y, then z (the contract's order).
  for (int j = 0; j < 3; ++j) {
    const float x00 = v[0][0][0][j] + (v[1][0][0][j] - v[0][0][0][j]) * f[0];
    const float x10 = v[0][1][0][j] + (v[1][1][0][j] - v[0][1][0][j]) * f[0];
    const float x01 = v[0][0][1][j] + (v[1][0][1][j] - v[0][0][1][j]) * f[0];
    const float x11 = v[0][1][1][j] + (v[1][1][1][j] - v[0][1][1][j]) * f[0];
    const float y0 = x00 + (x10 - x00) * f[1];
    const float y1 = x01 + (x11 - x01) * f[1];
    out[j] = y0 + (y1 - y0) * f[2];
  }
}

float pixel(const std::uint32_t* row, const Params& prm, float* pos_out) {
  const float unit = static_cast<float>(prm.unit);
  const F3 world_pos = unit * word_f3(row, 0);
  const F3 view = unit * word_f3(row, 18);
  const std::uint32_t seed = row[30];

  // Grid level, stepped logarithmically in the distance (Code 2, lines 10-15).
  const float z = std::sqrt(dot(view, view));
  const float e = std::floor(std::log2(0.3f * z + 3.0f)) / 0.3785116f;
  const float level_z = 0.1f * std::pow(1.3f, e) - 0.2f;
  const float level = 0.12f / level_z;
  const float sparkle_dens = static_cast<float>(prm.sparkle_density) * level;
  const float noise_dens = static_cast<float>(prm.noise_density) * level;

  // View vector remapping with domain repetition (lines 18-20), then the lookup (lines 23-24).
  const F3 v = view / z;
  F3 view_new = level_z * v;
  view_new = mul(sign3(view_new), fract3(abs3(view_new)));
  const F3 nv = view_new / std::sqrt(dot(view_new, view_new));
  F3 pos = sparkle_dens * world_pos + static_cast<float>(prm.view_dep) * nv;

  float noise[3];
  if (prm.noise == 1) {
    // Shopf's lookup jitter: the noise moves the lookup itself.
    const F3 q = noise_dens * world_pos;
    const float qa[3] = {q.x, q.y, q.z};
    noise3(qa, seed, noise);
    pos = pos + static_cast<float>(prm.noise_amount) * F3{noise[0], noise[1], noise[2]};
  }
  if (pos_out) {
    pos_out[0] = pos.x;
    pos_out[1] = pos.y;
    pos_out[2] = pos.z;
  }
  if (prm.shape == 1) {
    // Shopf's star (Code 1): lit where every coordinate is near a lattice plane.
    F3 p = fract3(pos);
    p = mul(p, F3{1.0f - p.x, 1.0f - p.y, 1.0f - p.z});
    const float s = 1.0f - static_cast<float>(prm.shopf_k) * (p.x + p.y + p.z);
    return std::isnan(s) ? s : std::fmin(std::fmax(s, 0.0f), 1.0f);
  }
  // The grid cell and the offset to its jittered centre (lines 27-33).
  const F3 g_index = floor3(pos);
  F3 P_x;
  if (prm.noise == 1) {
    P_x = add(pos - g_index, -0.5f);
  } else {
    const F3 P_c = g_index / sparkle_dens;
    const F3 q = noise_dens * P_c;
    const float qa[3] = {q.x, q.y, q.z};
    noise3(qa, seed, noise);
    const F3 nz = static_cast<float>(prm.noise_amount) * F3{noise[0], noise[1], noise[2]};
    P_x = add((pos - g_index) + 0.5f * fract3(add(nz, 0.5f)), -0.75f);
  }
  if (prm.anisotropic == 1) {
    // Lines 36-39: the component along the view's tangential direction ma scaled by |cos theta|.
    const F3 n = word_f3(row, 9);
    const float dotvn = dot(v, n);
    const F3 ma = v - dotvn * n;
    const F3 proj = dot(P_x, ma) * ma;
    P_x = P_x + ((std::fabs(dotvn) - 1.0f) * proj) / dot(ma, ma);
  }
  // The round kernel (lines 42-44). NaN compares false, as in the shader: NaN stays NaN.
  const float dist2 = dot(P_x, P_x);
  const float thresh = (1.0f - static_cast<float>(prm.sparkle_size)) * static_cast<float>(prm.kernel_scale);
  return dist2 > thresh ? 0.0f : 1.0f - dist2 / thresh;
}

void twin(const std::uint32_t* rows, std::size_t count, const Params& params, float* out, float* pos) {
  auto check_switch = [](const char* name, int value) {
    if (value != 0 && value != 1) glintlab::throw_invalid("", name, std::to_string(value), "0 or 1");
  };
  check_switch("shape", params.shape);
  check_switch("noise", params.noise);
  check_switch("anisotropic", params.anisotropic);
  detail::parallel_chunks(count, 4096, 16384, [&](std::size_t i0, std::size_t i1) {
    for (std::size_t i = i0; i < i1; ++i) out[i] = pixel(rows + i * kInputWords, params, pos ? pos + 3 * i : nullptr);
  });
}

}  // namespace glintlab::wb16
