// Glint images of scenes: the ground truth counted facet by facet (docs/math/glint_images.md).
//
// Facets of the stratified layout (one jittered facet per square cell of side 1/sqrt(N) of the
// texture plane, glintlab's DB23 layout) are counted in each pixel's footprint ellipse; a facet
// reflects when its uniform, drawn per angular texel, is below the pixel's p. Every value is a pure
// function of (seed, cell, texel), so an image is the same whatever the number of threads.
#pragma once

#include <cstddef>
#include <cstdint>

namespace glintlab::images {

// Per-pixel status of facet_counts.
enum class FacetStatus : std::uint8_t { kOk = 0, kDegenerate = 1, kNonFinite = 2, kTooLarge = 4 };

// K per pixel: the reflecting facets of the stratified layout of density N in the footprint ellipse
// J {|x| <= 1/sqrt(pi)} around uv (J = (du/dx, dv/dx, du/dy, dv/dy), as the grid counters take it),
// with the per-facet uniforms of angular texel floor(slope) (slope may be null: texel (0, 0)).
// p has 1 or m entries. Pixels whose ellipse spans more than max_cells cells get K = NaN and
// status kTooLarge. `tested` (may be null) receives the facets tested per pixel.
void facet_counts(double density, const double* p, std::size_t p_size, const double* uv, const double* jac,
                  const double* slope, std::size_t m, std::uint64_t seed, double max_cells, double* k_out,
                  std::uint8_t* status_out, double* tested_out);

}  // namespace glintlab::images
