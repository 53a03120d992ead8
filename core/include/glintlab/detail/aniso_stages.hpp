// The stages of AnisoCounter::count_pixels and sample (core/src/counting/aniso.cpp;
// docs/math/grids.md#grid-realizations): internal to the library and its tests. A call cuts its pixels into chunks;
// each pixel goes through
//
//   1. footprint terms  footprint_terms  the scheme's terms of the pixel's footprint (or the call's shared ones)
//   2. term cells       TermCells        each term's grid cells (vertices of the spatial and angular lattices, or
//                                        one picked), their keys and weights, gathered as rows for the inner law
//
// and then each chunk's gathered rows through
//
//   3. evaluate         evaluate_cells   each row's uniforms from its cell key, then the inner law
//   4. accumulate       accumulate_cells K of each pixel, the weighted counts summed in term order
//
// The seed enters at one place, through the pixel's seeds (Pixel::grid_seed, select_seed) in stage 2: the grid keys,
// the cells' keys and the vertex picks; stage 3 turns each row's cell key into its uniforms (a pure function of the
// key, no seed). So a cell's counts do not depend on the chunk, the thread or the pixel that reads it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "glintlab/counting/aniso.hpp"

namespace glintlab::detail {
class FixedEvaluator;
}

namespace glintlab::detail::aniso_stages {

using aniso::CounterOptions;
using aniso::GridId;
using aniso::GridScheme;
using aniso::Shape;
using aniso::ShapeStatus;
using aniso::Spatial;
using aniso::Term;

// A pixel as the stages read it: texture position, angular coordinate (texels), p, and its seeds.
struct Pixel {
  double u, v, su, sv, p;
  std::uint64_t grid_seed;    // keys the grids (and through them every cell's uniforms)
  std::uint64_t select_seed;  // keys the vertex picks of realization = select
};

// The inner-law evaluations a chunk gathers, one row per cell read: its trials, p, uniforms (stage 3), weight in K,
// count (stage 3), pixel, the cell's key (CellUniforms input) and the term's index in its pixel.
struct CellRows {
  std::vector<double> n, p, u, coef, k;
  std::vector<std::size_t> owner;
  std::vector<std::uint64_t> cell;
  std::vector<std::uint32_t> term;
  bool in_use = false;
  // Room for `rows` rows of nu uniforms; only grows (a chunk's rows are filled in order, so growing keeps them).
  void ensure_rows(std::size_t rows, std::size_t nu) {
    if (n.size() < rows) grow(rows, nu);
    if (u.size() < n.size() * nu) u.resize(n.size() * nu);
  }

 private:
  void grow(std::size_t rows, std::size_t nu);
};

// count_pixels' seeds: every pixel reads the grids of the call's seed (neighbours share cells) and picks vertices under
// image_select_seed(seed).
std::uint64_t image_select_seed(std::uint64_t seed);

// The inner law's uniforms of the cell with key `cell` (CellRows::cell): u[0 .. nu), a pure function of the key
// (splitmix64 outputs; a shader reads them from a hash or a noise texture).
void cell_uniforms(std::uint64_t cell, std::size_t nu, double* u);

// Stage 1, footprint terms. terms: the pixel's terms (the call's shared ones, computed once, or the scheme's for
// this footprint); status: kClamped where the scheme changed the footprint, else the shape's. False, with no terms,
// where the footprint is degenerate or not finite (K = 0).
inline bool footprint_terms(const GridScheme& scheme, double density, const Shape& shape,
                            const std::vector<Term>* shared, std::vector<Term>& terms, ShapeStatus& status) {
  status = shape.status;
  if (shape.status == ShapeStatus::kDegenerate || shape.status == ShapeStatus::kNonFinite) {
    terms.clear();
    return false;
  }
  if (shared) {
    // The same footprint for every pixel: its terms once (sample() computed them), not per pixel.
    if (terms.empty()) terms = *shared;
    return true;
  }
  terms.clear();
  if (scheme.terms(shape, density, terms)) status = ShapeStatus::kClamped;
  return true;
}

// Stage 2, term cells: where the pixel's seeds are read. gather() appends the rows of pixel i's term ti at
// rows[at ..) and returns how many (evaluations_per_term of the options): the term's grid coordinates of the pixel
// (rotated, stretched, offset), the vertices of the spatial and angular lattices around them (all of them with
// their interpolation weights, or one of each picked with probability equal to its weight under select_seed), and
// each vertex cell's key under the grid's key (grid_seed, scale, ratio, orientation) and the angular texel. A row's
// weight in K is the term's scale times its vertices' weights. Memos of the last angles' sines and cosines and of
// each term slot's grid key: neighbouring pixels mostly read the same grids (the same bits as computing them).
class TermCells {
 public:
  TermCells(const CounterOptions& options, std::size_t max_terms);
  std::size_t gather(const Pixel& px, std::size_t i, std::size_t ti, const Term& t, CellRows& rows, std::size_t at);
  // The same, defined inline in aniso.cpp for the counter's pixel loop (a call per term showed in its profile).
  inline std::size_t gather_inline(const Pixel& px, std::size_t i, std::size_t ti, const Term& t, CellRows& rows,
                                   std::size_t at);

 private:
  struct TrigMemo {
    std::uint64_t bits = 0;   // the angle +0.0
    double c = 1.0, s = 0.0;  // std::cos(+0.0), std::sin(+0.0) exactly
  };
  struct GridMemo {
    GridId grid{};
    std::uint64_t seed = 0, key = 0;
    bool set = false;
    std::int64_t texel_i = 0, texel_j = 0;  // the last angular texel read on this grid, and its key
    std::uint64_t texel = 0;
  };
  Spatial spatial_;
  Spatial angular_lattice_;
  bool select_;
  std::array<TrigMemo, 64> trig_;
  std::vector<GridMemo> grids_;
};

// Stage 3, evaluate: rows r < count get their uniforms from their cell keys, then their counts k from the inner law:
// grouped by term through `fixed` (one evaluator per term of a shared footprint, null where a term has none) or
// all at once through its per-pixel path. The same bits either way (an evaluator gives evaluate()'s).
void evaluate_cells(const InnerLaw& inner, const std::vector<std::shared_ptr<const FixedEvaluator>>* fixed,
                    CellRows& rows, std::size_t count);

// Stage 4, accumulate: k_out[owner] += coef * k over rows r < count in order (a pixel's rows are contiguous, in term
// order: the same sum as adding each term as it comes). A non-finite count throws std::invalid_argument naming it,
// its n and p (`where` first).
void accumulate_cells(const CellRows& rows, std::size_t count, double* k_out, const std::string& where);

}  // namespace glintlab::detail::aniso_stages
