// KPT25's point process lit by an extended light (docs/math/lighting.md#lighting-own-truths): every point in
// the footprint is a facet whose normal is T^-1 of its point in the disk U, tested with the lighting
// module's one "mirror direction hits the light" (LightHit).
#include <cmath>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "kpt25_internal.hpp"

namespace glintlab {

using namespace kpt25;

void Kpt25Ndf::light_counts(const double* uv, const double* jac, const double* h, const double* wo, std::size_t m,
                            std::uint64_t seed, const lighting::LightHit& hit, bool mirror, double* counts,
                            double* radiance, double* points) const {
  refuse_glint_anisotropy("light_counts");
  const double q_max = 1.0 / (kPi * p_.filter * p_.filter);
  if (!(q_max <= kFilterRadius * kFilterRadius))
    throw_invalid(kWhere, "filter", p_.filter, "a filter std >= 1 / (3 sqrt(pi)) for light counts");
  const int channels = hit.channels();
  detail::parallel_chunks(m, 1, 4, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      check_position("uv", uv, i, 2, cells_per_uv_);
      double v[3];
      if (!unit_vector(wo + 3 * i, v) || !(v[2] > 0.0))
        throw_invalid(kWhere, element("wo", i, 2), wo[3 * i + 2], "a finite view above the horizon");
      const GlintPixel px = pixel(jac, h, i);
      double* c = counts + i * static_cast<std::size_t>(channels);
      for (int k = 0; k < channels; ++k) c[k] = 0.0;
      radiance[i] = points[i] = 0.0;
      for (int l = 0; l < px.n_levels; ++l) {
        const int level = px.levels[l];
        const std::int64_t na = std::int64_t{1} << level;
        const CellRange all{0, na - 1, 0, na - 1};
        const SpatialRange s = spatial_cells(res_, px, level, uv[2 * i], uv[2 * i + 1]);
        const double n_cells = static_cast<double>(s.i1 - s.i0 + 1) * static_cast<double>(s.j1 - s.j0 + 1) *
                               static_cast<double>(na) * static_cast<double>(na);
        if (n_cells > kGlintMaxReferenceCells)
          throw_invalid(kWhere, row_name("J", i), row_value(jac + 4 * i, 4),
                        "a footprint whose light counts visit at most 2e8 cells (this one: " + format_value(n_cells) +
                            " at level " + std::to_string(level) + "; lower the density or the footprint)");
        for_each_point(
            res_, px, level, uv[2 * i], uv[2 * i + 1], seed, 0, all,
            [&](std::int64_t ci, std::int64_t cj, std::int64_t a, std::int64_t b, double mx, double my, double q) {
              if (q > q_max) return;
              const double keep = point_keep(p_, seed, level, ci, cj, a, b, px.weights[l]);
              if (keep == 0.0) return;
              points[i] += keep;
              const auto n = inverse_map(mx, my);
              double rad = 0.0;
              const int k = hit.hit({v[0], v[1], v[2]}, {n[0], n[1], n[2]}, rad, mirror);
              if (k < 0) return;
              c[k] += keep;
              radiance[i] += keep * rad;
            });
      }
    }
  });
}

}  // namespace glintlab
