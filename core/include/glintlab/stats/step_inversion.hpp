// Table inversion of a monotone step function of one uniform, exact by construction.
//
// Many constant-time laws map a uniform u through Phi^-1 and a floor (gated: floor(mu + sd z)); at a
// fixed (n, p) the result is a step function of u whose steps sit at analytic thresholds t_i
// (Phi((j - mu)/sd)). A batch of samples at one (n, p) can find its step with one table load instead
// of evaluating logs, square roots and rational functions per sample (the cost a shader pays once
// per pixel; a Monte Carlo study pays it 1e7 times): [0, 1) is cut into 2^b equal cells (64 per
// threshold up to 2^18 cells, so u * 2^b is exact); a cell that no threshold or guard band touches
// stores its value, the others (about 2%) store where to start a short scan of the thresholds.
// sample_rows() runs the lookups of a block of rows as AVX-512 gathers when the CPU has them.
//
// Exactness: the analytic t_i and the law's floating-point evaluation may disagree by a few ulps
// about which side of a step a u lies on. Every threshold therefore carries a guard band, wider
// than that disagreement by a factor >= 1e3; a u inside a band (or beyond the table's ends when the
// law continues there) gets no answer and the caller evaluates the law directly. So a table lookup
// returns what evaluate() returns, bit for bit (tests/cpp/test_law.cpp compares 1e7 draws).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace glintlab {

class StepInversion {
 public:
  // Thresholds ascending. For u outside every guard band:
  //   value(u) = base + #{i : thresholds[i] <= u},
  // and u below thresholds[0] (above the last) is answered only if exact_below (exact_above).
  StepInversion(std::vector<double> thresholds, std::vector<double> guards, double base, bool exact_below,
                bool exact_above);

  // The step's value, or a negative number when the caller must evaluate directly.
  double operator()(double u) const {
    std::size_t g = static_cast<std::size_t>(u * cells_scale_);
    if (g >= cells_) g = cells_ - 1;
    const std::int32_t v = cell(g);
    return v >= 0 ? base_ + static_cast<double>(v) : search(u);
  }

  // A sample built from the step value v of one uniform column, as the constant-time laws do:
  //   out = gate ? a + s * v + [u[extra_col] < extra_below] : 0,  gate = u[gate_col] < gate_below,
  // (a column of -1 drops its term: the gate is then always open, the extra term 0).
  struct Affine {
    double a = 0, s = 1;
    int gate_col = -1;
    double gate_below = 0;
    int extra_col = -1;
    double extra_below = 0;
  };
  // out[r] for rows r of k uniforms each (row r at u + r k), v from column `col`; rows whose v
  // needs direct evaluation get out[r] = direct(u + r k) instead. With vector gathers (AVX-512)
  // where the CPU has them; the same values as the scalar expression above either way.
  template <class Direct>
  void sample_rows(const double* u, std::size_t k, std::size_t col, std::size_t rows, const Affine& f, double* out,
                   Direct&& direct) const {
    constexpr std::size_t kChunk = 256;
    std::uint8_t mask[kChunk / 8];
    for (std::size_t r0 = 0; r0 < rows; r0 += kChunk) {
      const std::size_t n = rows - r0 < kChunk ? rows - r0 : kChunk;
      affine_rows(u + r0 * k, k, col, n, f, out + r0, mask);
      for (std::size_t g = 0; g < (n + 7) / 8; ++g)
        if (mask[g]) [[unlikely]]
          for (std::size_t l = 0; l < 8; ++l)
            if (mask[g] >> l & 1) out[r0 + 8 * g + l] = direct(u + (r0 + 8 * g + l) * k);
    }
  }
  std::size_t size() const { return t_.size(); }

  // The guard for a threshold t at standard-normal quantile z of a law whose step variable is
  // v = a + s h(z) (h' >= slope > 0 near z), |v| <= magnitude: covers the rounding of v (a few ulps
  // of magnitude), of Phi^-1 (relative 1e-15) and of Phi at t (absolute and relative), times 1e3.
  static double gaussian_guard(double t, double z, double s, double slope, double magnitude);

 private:
  double search(double u) const;
  // sample_rows for at most 256 rows: mask bit r set where direct evaluation is needed.
  void affine_rows(const double* u, std::size_t k, std::size_t col, std::size_t rows, const Affine& f, double* out,
                   std::uint8_t* mask) const;
  std::vector<double> t_, guard_;
  // Cell g: #{t <= u} for every u of the cell, or -1 - #{t <= left edge} (search). In 16 bits for a
  // table of 2^17 cells or more with fewer than 2^15 - 1 thresholds (cell16_, one spare element: the
  // vector path gathers 32 bits at each cell's address), so that 2^18 cells take 512 KiB and stay in
  // a core's L2 cache; else in cell_.
  std::int32_t cell(std::size_t g) const { return cell16_.empty() ? cell_[g] : cell16_[g]; }
  std::vector<std::int32_t> cell_;
  std::vector<std::int16_t> cell16_;
  std::size_t cells_ = 0;
  double cells_scale_;
  double base_;
  bool exact_below_, exact_above_;
};

// The steps of v(u) = clamp(floor(mean + sd Phi^-1(u) + shift), 0, top) (sd > 0), or nothing when
// they are more than max_steps or their guard bands would cover more than 1e-3 of [0, 1].
std::optional<StepInversion> floor_gaussian_steps(double mean, double sd, double shift, double top,
                                                  std::size_t max_steps = 1 << 16);

}  // namespace glintlab
