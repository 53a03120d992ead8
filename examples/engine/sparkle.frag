#version 450
// A fragment shader's glint term, engine style (written for glintlab's guide, docs/guide/engine_code.md):
// sparkles on a jittered grid over uv whose level follows the pixel's footprint (fwidth of the uv), so a
// sparkle stays about a pixel wide at any distance, each lit where its random number falls under a
// Blinn-Phong lobe around the half vector. Varyings from the vertex stage, loose uniforms, one output.
layout(location = 0) in vec2 vUv;
layout(location = 1) in vec3 vNormal;
layout(location = 2) in vec3 vViewDir;   // surface to camera
uniform vec3 uLightDir;                  // surface to light, unit
uniform float uSparkleDensity;           // cells per uv unit at the finest level
uniform float uSparkleSize;              // a sparkle's radius in cells
uniform float uShininess;                // the lobe's Blinn-Phong exponent
layout(location = 0) out vec4 fragColor;

float hash12(vec2 p) {
  vec3 p3 = fract(vec3(p.xyx) * 0.1031);
  p3 += dot(p3, p3.yzx + 33.33);
  return fract((p3.x + p3.y) * p3.z);
}

void main() {
  vec2 footprint = fwidth(vUv) * uSparkleDensity;            // cells per pixel at the finest level
  float level = max(0.0, ceil(log2(max(footprint.x, footprint.y))));
  float scale = uSparkleDensity / exp2(level);
  vec2 cellPos = vUv * scale;
  vec2 cell = floor(cellPos) + level * 1024.0;               // each level its own random numbers
  vec2 jitter = vec2(hash12(cell), hash12(cell + 17.0));
  float inside = step(length(fract(cellPos) - jitter), uSparkleSize);
  vec3 h = normalize(uLightDir + normalize(vViewDir));
  float lobe = pow(max(dot(normalize(vNormal), h), 0.0), uShininess);
  float sparkle = inside * step(hash12(cell + 31.0), lobe);
  fragColor = vec4(vec3(sparkle), 1.0);
}
