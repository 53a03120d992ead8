// WB16's sparkle effect (their Appendix A, Code 2) as a glintlab method shader: the sparkle intensity
// in [0, 1] per pixel, to be multiplied by the lighting. Transcription and every reading where the
// printed code is ambiguous: docs/math/glint_images.md#glint-wb16. The body of wb16.hlsl and
// wb16.glsl (which include glintlab_method_<language>.h first), written in what the two languages
// share, so both compute the same operations. Its C++ twin, which must agree with it pixel by pixel,
// is core/src/glinty/wb16.cpp (glintlab.api.method_shaders.wb16_twin; wb16_twin_numpy is the numpy one).
#ifndef WB16_BODY_H
#define WB16_BODY_H

// Parameters (-D NAME=value; shader_method(defines=...)). The paper gives no values: ours.
#ifndef WB16_SPARKLE_SIZE
#define WB16_SPARKLE_SIZE 0.9      // sparkle_size: the kernel keeps dist2 <= 1 - size (in grid cells^2)
#endif
#ifndef WB16_SPARKLE_DENSITY
#define WB16_SPARKLE_DENSITY 30.0  // sparkle_dens: grid cells per paper unit at level 1
#endif
#ifndef WB16_VIEW_DEP
#define WB16_VIEW_DEP 1.0          // view_dep: grid cells the remapped view direction shifts the lookup by
#endif
#ifndef WB16_NOISE_AMOUNT
#define WB16_NOISE_AMOUNT 1.0      // noise_amt
#endif
#ifndef WB16_NOISE_DENSITY
#define WB16_NOISE_DENSITY 1.0     // noise_dens: noise texture periods per paper unit at level 1
#endif
#ifndef WB16_UNIT
#define WB16_UNIT 10.0             // paper units per scene unit: Code 2's level needs distances > 10/3
#endif
#ifndef WB16_SHAPE
#define WB16_SHAPE 0               // 0: WB16's round kernel (lines 42-44); 1: Shopf's star (Code 1)
#endif
#ifndef WB16_SHOPF_K
#define WB16_SHOPF_K 3.0           // Code 1's k (the star's size: it is lit where the three p(1 - p) sum below 1 / k)
#endif
#ifndef WB16_NOISE
#define WB16_NOISE 0               // 0: noise jitters the grid centres (lines 31-33); 1: Shopf's lookup jitter
#endif
#ifndef WB16_ANISOTROPIC
#define WB16_ANISOTROPIC 1         // 1: the anisotropic kernel of lines 36-39; 0: a sphere
#endif
#ifndef WB16_KERNEL_SCALE
#define WB16_KERNEL_SCALE 1.0      // multiplies the threshold 1 - size (1: as printed; tests break it)
#endif
#ifndef WB16_NOISE_TEXTURE
#define WB16_NOISE_TEXTURE 0       // 0: glintlab's hashed value noise; 1: WB16's own, a 3D noise texture
#endif

// WB16 read their noise from a 3D texture. glintlab's default hashes it (glintlab_noise3: the texture a
// 128^3 wrapped, trilinearly filtered grid of hashed cell values would be, with no texture to bind);
// WB16_NOISE_TEXTURE 1 reads the real texture, WB16NoiseTex (128^3, 3 channels, linear, wrap), which
// glintlab.api.method_shaders.wb16_noise_texture fills with those cell values for one seed (the
// texture does not change with GlintInput's seed).
#if WB16_NOISE_TEXTURE == 1
#if defined(GLINTLAB_GLSL)
uniform sampler3D WB16NoiseTex;
#define WB16_NOISE3(p, seed) textureLod(WB16NoiseTex, (p), 0.0).xyz
#else
Texture3D<float4> WB16NoiseTex;
SamplerState WB16NoiseSampler;
#define WB16_NOISE3(p, seed) WB16NoiseTex.SampleLevel(WB16NoiseSampler, (p), 0).xyz
#endif
#else
#define WB16_NOISE3(p, seed) glintlab_noise3((p), (seed))
#endif

float glint(GlintInput g) {
  float3 world_pos = g.world_pos * WB16_UNIT;
  float3 view = g.view * WB16_UNIT;
  float sparkle_dens = WB16_SPARKLE_DENSITY;
  float noise_dens = WB16_NOISE_DENSITY;

  // Grid level, stepped logarithmically in the distance (lines 10-15): 0.3785116 = log2(1.3), so
  // pow(1.3, e) = 2^floor(log2(0.3 z + 3)).
  float z = length(view);
  float e = floor(log2(0.3 * z + 3.0)) / 0.3785116;
  float level_z = 0.1 * pow(1.3, e) - 0.2;
  float level = 0.12 / level_z;
  sparkle_dens *= level;
  noise_dens *= level;

  // View vector remapping with domain repetition (lines 18-20).
  float3 v = view / z;
  float3 view_new = v * level_z;
  view_new = sign(view_new) * frac(abs(view_new));

  // Grid lookup position (lines 23-24).
  float3 pos = sparkle_dens * world_pos + WB16_VIEW_DEP * normalize(view_new);

#if WB16_NOISE == 1
  // Shopf's baseline: the noise jitters the lookup itself (distorting the sparkle's shape); the
  // sparkle then sits at the cell's centre.
  pos += WB16_NOISE_AMOUNT * WB16_NOISE3(noise_dens * world_pos, g.seed);
#endif

#if WB16_SHAPE == 1
  // Shopf's star (Code 1) on the lookup position: bright where every coordinate is near a lattice plane.
  float3 p = frac(pos);
  p *= 1.0 - p;
  return clamp(1.0 - WB16_SHOPF_K * (p.x + p.y + p.z), 0.0, 1.0);
#else
  // The grid and its cell (lines 27-28).
  float3 g_index = floor(pos);
  float3 P_c = g_index / sparkle_dens;
#if WB16_NOISE == 1
  float3 P_x = pos - g_index - 0.5;
#else
  // Offset to the jittered cell centre (lines 31-33): the centre lies in [0.25, 0.75) of the cell.
  float3 noise = WB16_NOISE_AMOUNT * WB16_NOISE3(noise_dens * P_c, g.seed);
  float3 offset = float3(0.75, 0.75, 0.75);
  float3 P_x = pos - g_index + 0.5 * frac(noise + 0.5) - offset;
#endif
#if WB16_ANISOTROPIC == 1
  // Anisotropy (lines 36-39): the component of P_x along the view's tangential direction ma is scaled
  // by |cos theta|, elongating the kernel along ma.
  float dotvn = dot(v, g.n);
  float3 ma = v - dotvn * g.n;
  float3 P_x_proj = dot(P_x, ma) * ma;
  P_x += (abs(dotvn) - 1.0) * P_x_proj / dot(ma, ma);
#endif
  // The round kernel: an inverted squared distance (lines 42-44).
  float dist2 = dot(P_x, P_x);
  float thresh = (1.0 - WB16_SPARKLE_SIZE) * WB16_KERNEL_SCALE;
  return dist2 > thresh ? 0.0 : 1.0 - dist2 / thresh;
#endif
}

#endif
