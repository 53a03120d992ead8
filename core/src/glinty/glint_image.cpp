// The ground truth of glint images: stratified facets counted in each pixel's footprint ellipse
// (docs/math/glint_images.md#glint-truth).
#include "glintlab/glinty/glint_image.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "base/parallel.hpp"
#include "base/splitmix.hpp"
#include "glintlab/base/errors.hpp"

namespace glintlab::images {

namespace {
using glintlab::detail::mix64;
std::uint64_t cell_hash(std::uint64_t key, std::int64_t i, std::int64_t j) {
  return mix64(key + static_cast<std::uint64_t>(i) * 0xD1B54A32D192ED03ULL +
               static_cast<std::uint64_t>(j) * 0xABC98388FB8FAC03ULL);
}
double unit53(std::uint64_t x) { return (static_cast<double>(x >> 11) + 0.5) * 0x1.0p-53; }
double unit32(std::uint32_t x) { return (static_cast<double>(x) + 0.5) * 0x1.0p-32; }
constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kChunk = 64;

void fail(const std::string& what, double value, const std::string& expected) {
  throw_invalid_message("facet_counts: " + what + " = " + format_value(value) + " is invalid; expected " + expected);
}
}  // namespace

void facet_counts(double density, const double* p, std::size_t p_size, const double* uv, const double* jac,
                  const double* slope, std::size_t m, std::uint64_t seed, double max_cells, double* k_out,
                  std::uint8_t* status_out, double* tested_out) {
  if (!(std::isfinite(density) && density > 0)) fail("density", density, "a finite facet density > 0");
  if (!(max_cells >= 1)) fail("max_cells", max_cells, "a number >= 1");
  check_length("facet_counts", "p", p_size, m);
  for (std::size_t i = 0; i < p_size; ++i)
    if (!(p[i] >= 0.0 && p[i] <= 1.0)) fail("p[" + std::to_string(i) + "]", p[i], "a probability in [0, 1]");
  for (std::size_t i = 0; i < 2 * m; ++i) {
    if (!std::isfinite(uv[i]) || std::abs(uv[i]) > 1e9)
      fail("uv[" + std::to_string(i / 2) + "]", uv[i], "a finite texture coordinate, |uv| <= 1e9");
    if (slope && (!std::isfinite(slope[i]) || std::abs(slope[i]) > 1e9))
      fail("slope[" + std::to_string(i / 2) + "]", slope[i], "a finite angular coordinate, |slope| <= 1e9");
  }
  const double c = 1.0 / std::sqrt(density);  // cell side
  const std::uint64_t pos_key = mix64(seed ^ 0x6A09E667F3BCC909ULL);
  const std::uint64_t refl_key = mix64(seed ^ 0xBB67AE8584CAA73BULL);
  detail::parallel_chunks(m, kChunk, kChunk, [&](std::size_t i0, std::size_t i1) {
    for (std::size_t q = i0; q < i1; ++q) {
      k_out[q] = 0.0;
      if (tested_out) tested_out[q] = 0.0;
      const double a = jac[4 * q], cc = jac[4 * q + 1], b = jac[4 * q + 2], d = jac[4 * q + 3];
      // J = [[a, b], [cc, d]] (du/dx, du/dy; dv/dx, dv/dy); S = J J^T = [[A, C], [C, B]].
      if (!(std::isfinite(a) && std::isfinite(b) && std::isfinite(cc) && std::isfinite(d))) {
        status_out[q] = static_cast<std::uint8_t>(FacetStatus::kNonFinite);
        continue;
      }
      const double det = a * d - b * cc;
      const double A = a * a + b * b, B = cc * cc + d * d, C = a * cc + b * d;
      if (!(std::abs(det) > 0) || !(B > 0) || !(A > 0) || A * B > 1e24 * det * det) {
        status_out[q] = static_cast<std::uint8_t>(FacetStatus::kDegenerate);
        continue;
      }
      const double umax = std::sqrt(A / kPi), vmax = std::sqrt(B / kPi);
      const double u0 = uv[2 * q], v0 = uv[2 * q + 1];
      const std::int64_t j_lo = static_cast<std::int64_t>(std::floor((v0 - vmax) / c));
      const std::int64_t j_hi = static_cast<std::int64_t>(std::floor((v0 + vmax) / c));
      const double cells = (2 * umax / c + 2) * static_cast<double>(j_hi - j_lo + 1);
      if (!(cells <= max_cells)) {
        k_out[q] = std::nan("");
        status_out[q] = static_cast<std::uint8_t>(FacetStatus::kTooLarge);
        continue;
      }
      status_out[q] = static_cast<std::uint8_t>(FacetStatus::kOk);
      const double pq = p[p_size == 1 ? 0 : q];
      // Inside: (B du^2 - 2 C du dv + A dv^2) <= det^2 / pi, with (du, dv) = facet - centre.
      const double lim = det * det / kPi;
      const std::int64_t tu = slope ? static_cast<std::int64_t>(std::floor(slope[2 * q])) : 0;
      const std::int64_t tv = slope ? static_cast<std::int64_t>(std::floor(slope[2 * q + 1])) : 0;
      const std::uint64_t texel = mix64(refl_key + static_cast<std::uint64_t>(tu) * 0xE7037ED1A0B428DBULL +
                                        static_cast<std::uint64_t>(tv) * 0x8EBC6AF09C88C6E3ULL);
      const double adet = std::abs(det);
      std::int64_t count = 0, tests = 0;
      for (std::int64_t j = j_lo; j <= j_hi; ++j) {
        // The band of this row relative to the centre, clipped to the ellipse's v-extent.
        const double jd = static_cast<double>(j);
        const double lo = std::max(jd * c - v0, -vmax), hi = std::min((jd + 1) * c - v0, vmax);
        if (lo > hi) continue;
        // u-interval of the ellipse at dv: (C dv -+ |det| sqrt(vmax^2 - dv^2)) / B; a superset over the band.
        const double near0 = lo > 0 ? lo : (hi < 0 ? hi : 0.0);
        const double half = adet * std::sqrt(std::max(vmax * vmax - near0 * near0, 0.0)) / B;
        const double cen_lo = C * std::min(lo, hi) / B, cen_hi = C * std::max(lo, hi) / B;
        const double ulo = std::min(cen_lo, cen_hi) - half, uhi = std::max(cen_lo, cen_hi) + half;
        const std::int64_t i_lo = static_cast<std::int64_t>(std::floor((u0 + ulo) / c));
        const std::int64_t i_hi = static_cast<std::int64_t>(std::floor((u0 + uhi) / c));
        for (std::int64_t i = i_lo; i <= i_hi; ++i) {
          const std::uint64_t h = cell_hash(pos_key, i, j);
          const double fu = (static_cast<double>(i) + unit32(static_cast<std::uint32_t>(h))) * c - u0;
          const double fv = (static_cast<double>(j) + unit32(static_cast<std::uint32_t>(h >> 32))) * c - v0;
          ++tests;
          if (B * fu * fu - 2 * C * fu * fv + A * fv * fv > lim) continue;
          if (unit53(cell_hash(texel, i, j)) < pq) ++count;
        }
      }
      k_out[q] = static_cast<double>(count);
      if (tested_out) tested_out[q] = static_cast<double>(tests);
    }
  });
}

}  // namespace glintlab::images
