// Counter-based random numbers keyed by coordinates (Philox4x32-10, Salmon et al. 2011, from
// Debian's Random123). A draw is a pure function of (seed, x, y, level, stream, draw index): a law
// evaluated for grid cell (x, y) at LOD `level` gets the same numbers in every run, thread and pixel,
// and sample i of a batch gets the same numbers whatever the number of threads.
//
// Layout: Philox key = the 64-bit seed; counter = (draw block, x, y, level << 16 | stream).
// One block yields 4 x 32 bits = two 53-bit doubles.
#pragma once

#include <Random123/philox.h>

#include <array>
#include <cstdint>

namespace glintlab {

// Well-known stream ids, so that unrelated uses of one seed never share numbers. Later users
// (grid cells, LOD levels) take their own ids here.
enum Stream : std::uint16_t {
  // law.sample() and gl.uniforms(): sample i keyed by x = low 32 bits of i, y = high 32 bits. One
  // stream for both on purpose: a custom law fed gl.uniforms() reproduces a built-in's samples.
  kStreamSample = 0,
  // Ground-truth realizations (spatial.hpp): realization r keyed by x, y = low, high bits of r.
  kStreamGroundTruth = 2,
  // LOD cells (blend.hpp): the inner law's uniforms of cell (x, y) at a level, and the per-facet
  // decisions (Russian roulette) of the same cell.
  kStreamLevelCount = 3,
  kStreamLevelFacets = 4,
  // Anisotropic grids (aniso.hpp): the inner law's uniforms of a grid cell and angular texel, the
  // per-pixel choice of one interpolation vertex, and the random positions of sample().
  kStreamAnisoCell = 5,
  kStreamAnisoSelect = 6,
  kStreamAnisoPosition = 7,
};

class CounterRng {
 public:
  CounterRng(std::uint64_t seed, std::uint32_t x, std::uint32_t y, std::uint16_t level = 0, std::uint16_t stream = 0) {
    key_ = {{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)}};
    ctr_ = {{0u, x, y, (static_cast<std::uint32_t>(level) << 16) | stream}};
  }

  // The generator of sample `index` of a batch.
  static CounterRng for_index(std::uint64_t seed, std::uint64_t index, std::uint16_t stream) {
    return CounterRng(seed, static_cast<std::uint32_t>(index), static_cast<std::uint32_t>(index >> 32), 0, stream);
  }

  // Uniform double in the open interval (0, 1): (m + 1/2) 2^-53 with m a 53-bit integer, so that
  // log(u), log(1 - u) and inverse CDFs never see 0 or 1.
  double uniform() {
    if (pos_ == 2) refill();
    const std::uint64_t bits = (static_cast<std::uint64_t>(out_[2 * pos_]) << 32) | out_[2 * pos_ + 1];
    ++pos_;
    return (static_cast<double>(bits >> 11) + 0.5) * 0x1.0p-53;
  }

  // Skips the next `blocks` Philox blocks without computing them (they were taken elsewhere, e.g.
  // from the vectorized rows); only at a block boundary (before the first uniform() or after an
  // even number of them), where the next uniform() starts a block.
  void skip_blocks(std::uint32_t blocks) { ctr_.v[0] += blocks; }

  // Raw Philox4x32-10 block for (counter, key): exposed for known-answer tests.
  static std::array<std::uint32_t, 4> block(const std::array<std::uint32_t, 4>& counter,
                                            const std::array<std::uint32_t, 2>& key) {
    r123::Philox4x32 gen;
    r123::Philox4x32::ctr_type c = {{counter[0], counter[1], counter[2], counter[3]}};
    r123::Philox4x32::key_type k = {{key[0], key[1]}};
    auto r = gen(c, k);
    return {r[0], r[1], r[2], r[3]};
  }

 private:
  void refill() {
    out_ = gen_(ctr_, key_);
    ctr_.v[0] += 1;  // 2^32 blocks = 2^33 doubles per key: far beyond any law's needs
    pos_ = 0;
  }

  r123::Philox4x32 gen_;
  r123::Philox4x32::ctr_type ctr_;
  r123::Philox4x32::key_type key_;
  r123::Philox4x32::ctr_type out_{};
  int pos_ = 2;
};

}  // namespace glintlab
