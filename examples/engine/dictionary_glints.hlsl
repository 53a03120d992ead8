// A texture-reading glint method, engine style (written for glintlab's guide, docs/guide/engine_code.md):
// a grid of glint cells over the surface's uv, each cell's random number read from a tiled texture of
// precomputed random numbers, and the chance that a cell sparkles read from a 1D table over the half
// vector's angle to the normal (a tiny "NDF dictionary" in a structured buffer). The material's
// parameters live in a cbuffer. glintlab binds all three by the names declared here.
Texture2D<float> GlintRandomTex;        // RANDOM_TILE x RANDOM_TILE uniform random numbers, tiled over the cells
SamplerState PointWrap;                 // read without filtering: one number per cell
StructuredBuffer<float> NdfDictionary;  // DICTIONARY_BINS values over theta_h in [0, pi/2)

cbuffer GlintMaterial {
  float GridScale;   // cells per uv unit
  float Threshold;   // the share of cells that sparkle where the table reads 1
  float Intensity;   // a sparkle's brightness
};

#define RANDOM_TILE 64.0
#define DICTIONARY_BINS 32u
static const float kHalfPi = 1.5707963;

float glint(GlintInput g) {
  float2 cell = floor(g.uv * GridScale);
  float r = GlintRandomTex.SampleLevel(PointWrap, (cell + 0.5) / RANDOM_TILE, 0);
  float theta = acos(saturate(dot(normalize(g.h), normalize(g.n))));
  uint bin = min(uint(theta / kHalfPi * float(DICTIONARY_BINS)), DICTIONARY_BINS - 1u);
  return r < Threshold * NdfDictionary[bin] ? Intensity : 0.0;
}
