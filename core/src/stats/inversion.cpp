#include "glintlab/stats/inversion.hpp"

namespace glintlab {

SmallMeanInversion::SmallMeanInversion(double f0, double a, double s, double bound, bool tabulate)
    : f0_(f0), a_(a), s_(s), bound_(bound) {
  if (!tabulate) return;
  const auto size = static_cast<std::size_t>(bound) + 1;
  cum_.resize(size);
  double f = f0, c = f0;  // the very operations of the on-the-fly search, in the same order
  cum_[0] = c;
  for (std::size_t k = 1; k < size; ++k) {
    f *= a / static_cast<double>(k) - s;
    c += f;
    cum_[k] = c;
  }
  std::size_t g = 1;
  while (g < 2 * size) g *= 2;
  guide_.resize(g);
  guide_scale_ = static_cast<double>(g);
  std::size_t k = 0;
  for (std::size_t j = 0; j < g; ++j) {
    const double level = static_cast<double>(j) / guide_scale_;
    while (k < size && cum_[k] < level) ++k;
    guide_[j] = static_cast<std::uint32_t>(k);
  }
}

}  // namespace glintlab
