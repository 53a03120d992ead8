// Private helper of core/src/lighting*.cpp: globally adaptive Gauss-Kronrod (7-15) quadrature of a
// vector-valued integrand on [a, b], started from given breakpoints (docs/math/lighting.md#lighting-cubature).
//
// Each piece carries the 15-point Kronrod estimate and QUADPACK's error estimate (|Kronrod - Gauss|
// rescaled, conservative for smooth integrands; Piessens et al. 1983, qk15). The piece with the
// largest error of the component furthest from its tolerance is bisected until every component c has
// total error <= max(rel |I_c|, abs_c), or the evaluation budget runs out (`converged` false).
// Breakpoints matter: a feature narrower than the spacing of the 15 nodes is invisible to the error
// estimate, so callers split where the integrand may be peaked (the lighting code splits
// geometrically around the NDF's peak).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace glintlab::lighting::detail {

// QUADPACK's qk15 nodes (the Kronrod abscissae, decreasing; index 7 is the centre) and weights; the
// 7-point Gauss rule uses the odd-indexed nodes 1, 3, 5 and the centre.
inline constexpr double kXgk[8] = {0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                                   0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                                   0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                                   0.207784955007898467600689403773245, 0.0};
inline constexpr double kWgk[8] = {0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                                   0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                                   0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                                   0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
inline constexpr double kWg[4] = {0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                                  0.381830050505118944950369775488975, 0.417959183673469387755102040816327};

struct VectorIntegral {
  std::vector<double> value, error;
  std::int64_t evaluations = 0;
  bool converged = true;
};

struct Piece {
  double a, b;
  std::vector<double> k, err;
};

// fn(x, out) writes `dim` values at x.
template <class F>
void gk15(F& fn, int dim, Piece& piece, std::vector<double>& buf, std::vector<double>& gauss) {
  const double c = 0.5 * (piece.a + piece.b), h = 0.5 * (piece.b - piece.a);
  piece.k.assign(dim, 0.0);
  gauss.assign(dim, 0.0);
  buf.resize(16 * dim);
  double* values = buf.data();
  for (int j = 0; j < 8; ++j) {
    const int pairs = j == 7 ? 1 : 2;
    for (int s = 0; s < pairs; ++s) {
      double* out = values + (2 * j + s) * dim;
      fn(j == 7 ? c : (s == 0 ? c - h * kXgk[j] : c + h * kXgk[j]), out);
      for (int d = 0; d < dim; ++d) {
        piece.k[d] += kWgk[j] * out[d];
        if (j % 2 == 1) gauss[d] += kWg[j / 2] * out[d];
      }
    }
  }
  piece.err.assign(dim, 0.0);
  for (int d = 0; d < dim; ++d) {
    // QUADPACK's estimate: |K - G| scaled by the integrand's spread about its mean on the piece (resasc),
    // err = resasc min(1, (200 |K - G| / resasc)^1.5), never below 50 ulps of the absolute integral.
    const double mean = 0.5 * piece.k[d];
    double resasc = 0, resabs = 0;
    for (int j = 0; j < 8; ++j) {
      const int pairs = j == 7 ? 1 : 2;
      for (int s = 0; s < pairs; ++s) {
        const double f = values[(2 * j + s) * dim + d];
        resasc += kWgk[j] * std::abs(f - mean);
        resabs += kWgk[j] * std::abs(f);
      }
    }
    piece.k[d] *= h;
    resasc *= std::abs(h);
    resabs *= std::abs(h);
    double err = std::abs(piece.k[d] - h * gauss[d]);
    if (resasc != 0 && err != 0) err = resasc * std::min(1.0, std::pow(200 * err / resasc, 1.5));
    piece.err[d] = std::max(err, 50 * 2.220446049250313e-16 * resabs);
  }
}

// `points`: sorted breakpoints, the first and last the interval's ends (at least two).
template <class F>
VectorIntegral adaptive_gk(F&& fn, int dim, const std::vector<double>& points, double rel,
                           const std::vector<double>& abs, std::int64_t max_evaluations) {
  std::vector<Piece> pieces;
  std::vector<double> buf, gauss;
  VectorIntegral out;
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    if (!(points[i + 1] > points[i])) continue;
    pieces.push_back({points[i], points[i + 1], {}, {}});
    gk15(fn, dim, pieces.back(), buf, gauss);
    out.evaluations += 15;
  }
  out.value.assign(dim, 0.0);
  out.error.assign(dim, 0.0);
  for (;;) {
    std::fill(out.value.begin(), out.value.end(), 0.0);
    std::fill(out.error.begin(), out.error.end(), 0.0);
    for (const auto& p : pieces)
      for (int d = 0; d < dim; ++d) out.value[d] += p.k[d], out.error[d] += p.err[d];
    int worst = -1;
    double worst_ratio = 1.0;
    for (int d = 0; d < dim; ++d) {
      const double tol = std::max(rel * std::abs(out.value[d]), abs[d]);
      const double ratio = tol > 0 ? out.error[d] / tol : (out.error[d] > 0 ? INFINITY : 0.0);
      if (ratio > worst_ratio) worst_ratio = ratio, worst = d;
    }
    if (worst < 0 || pieces.empty()) return out;
    if (out.evaluations + 30 > max_evaluations) {
      out.converged = false;
      return out;
    }
    std::size_t split = 0;
    for (std::size_t i = 1; i < pieces.size(); ++i)
      if (pieces[i].err[worst] > pieces[split].err[worst]) split = i;
    const double mid = 0.5 * (pieces[split].a + pieces[split].b);
    if (!(mid > pieces[split].a && mid < pieces[split].b)) {  // at the resolution of doubles: accept
      pieces[split].err.assign(dim, 0.0);
      continue;
    }
    Piece right{mid, pieces[split].b, {}, {}};
    pieces[split].b = mid;
    gk15(fn, dim, pieces[split], buf, gauss);
    gk15(fn, dim, right, buf, gauss);
    pieces.push_back(std::move(right));
    out.evaluations += 30;
  }
}

// Breakpoints of [a, b]: the ends, `centre` if inside, and centre +- scale 2^k inside (k = 0, 1, ...):
// pieces that grow geometrically away from a feature of width about `scale` at `centre`.
inline std::vector<double> geometric_points(double a, double b, double centre, double scale) {
  std::vector<double> pts{a, b};
  if (scale > 0 && std::isfinite(centre)) {
    if (centre > a && centre < b) pts.push_back(centre);
    for (double s = scale; s < (b - a); s *= 2) {
      if (centre - s > a && centre - s < b) pts.push_back(centre - s);
      if (centre + s > a && centre + s < b) pts.push_back(centre + s);
    }
  }
  std::sort(pts.begin(), pts.end());
  return pts;
}

}  // namespace glintlab::lighting::detail
