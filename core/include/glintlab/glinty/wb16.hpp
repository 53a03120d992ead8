// WB16's sparkle shader (their Appendix A, Code 2) in C++: the float32 twin of the shipped method shader
// data/shaders/wb16_body.h, operation for operation in the same order, so that the two can be compared
// pixel by pixel (docs/math/glint_images.md#glint-wb16). Per pixel it reads the same 32-word rows the
// shader's wrapper kernel reads (method_shaders.pack_inputs: world_pos at word 0, n at 9, view at 18,
// seed at 30, every float a float32 bit pattern).
#pragma once

#include <cstddef>
#include <cstdint>

namespace glintlab::wb16 {

// The shader's -D parameters (WB16_<NAME>), with its defaults. Floats are rounded to float32 once,
// as the shader's float literals are.
struct Params {
  double sparkle_size = 0.9;      // the round kernel keeps dist2 <= (1 - size) * kernel_scale
  double sparkle_density = 30.0;  // grid cells per paper unit at level 1
  double view_dep = 1.0;          // cells the remapped view direction shifts the lookup by
  double noise_amount = 1.0;
  double noise_density = 1.0;  // noise texture periods per paper unit at level 1
  double unit = 10.0;          // paper units per scene unit
  int shape = 0;               // 0: the round kernel; 1: Shopf's star (Code 1)
  double shopf_k = 3.0;        // Code 1's k
  int noise = 0;               // 0: noise on the grid centres; 1: Shopf's lookup jitter
  int anisotropic = 1;         // 1: the anisotropic kernel of lines 36-39
  double kernel_scale = 1.0;   // multiplies the kernel's threshold (1: as printed)
};

// The method contract's row width (kMethodInputWords of glintlab/validation/method_shader.hpp;
// bindings/method_shaders.cpp asserts they agree): the twin reads the first 31 words only.
constexpr std::size_t kInputWords = 38;

// Three values in [0, 1) of a lattice cell and a seed (glintlab_cell_values of the method contract).
void cell_values(std::int64_t cx, std::int64_t cy, std::int64_t cz, std::uint32_t seed, float out[3]);
// The hashed value noise of the contract (glintlab_noise3): a wrapped, trilinearly read 128^3 texture.
void noise3(const float p[3], std::uint32_t seed, float out[3]);

// One pixel: the sparkle intensity, and the lookup position `pos` (3 floats; may be null).
float pixel(const std::uint32_t* row, const Params& params, float* pos);

// `count` rows of kInputWords words: out[i] = pixel(row i), pos (3 per row) when not null. Threads
// split the rows; every row is independent, so the result does not depend on the thread count.
// Throws std::invalid_argument (ValueError) for a switch outside {0, 1}.
void twin(const std::uint32_t* rows, std::size_t count, const Params& params, float* out, float* pos);

}  // namespace glintlab::wb16
