#include "glintlab/stats/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "glintlab/base/errors.hpp"

namespace glintlab {

namespace {

struct Named {
  const char* name;
  Metric metric;
};
constexpr Named kMetrics[] = {{"tv", Metric::kTV},
                              {"chi2_distance", Metric::kChi2Distance},
                              {"hellinger", Metric::kHellinger},
                              {"kl", Metric::kKL},
                              {"js", Metric::kJS},
                              {"w1", Metric::kW1},
                              {"ks", Metric::kKS}};

// Walks the union of both supports in increasing order, calling f(x, a_x, b_x).
template <class F>
void for_each_aligned(const Distribution& a, const Distribution& b, F f) {
  const auto &xa = a.support(), &xb = b.support(), &pa = a.probs(), &pb = b.probs();
  std::size_t i = 0, j = 0;
  while (i < xa.size() || j < xb.size()) {
    if (j == xb.size() || (i < xa.size() && xa[i] < xb[j])) {
      f(xa[i], pa[i], 0.0);
      ++i;
    } else if (i == xa.size() || xb[j] < xa[i]) {
      f(xb[j], 0.0, pb[j]);
      ++j;
    } else {
      f(xa[i], pa[i], pb[j]);
      ++i;
      ++j;
    }
  }
}

double kl_term(double x, double y) {
  if (x <= 0.0) return 0.0;
  if (y <= 0.0) return std::numeric_limits<double>::infinity();
  return x * std::log(x / y);
}

}  // namespace

Metric metric_from_name(const std::string& name) { return parse_enum("distance", "metric", name, kMetrics); }

std::string metric_name(Metric metric) {
  for (const auto& m : kMetrics)
    if (metric == m.metric) return m.name;
  return "?";
}

std::vector<std::string> metric_names() {
  std::vector<std::string> out;
  for (const auto& m : kMetrics) out.emplace_back(m.name);
  return out;
}

double distance(const Distribution& a, const Distribution& b, Metric metric) {
  double acc = 0.0;
  switch (metric) {
    case Metric::kTV:
      for_each_aligned(a, b, [&](double, double x, double y) { acc += std::abs(x - y); });
      return std::min(1.0, 0.5 * acc);
    case Metric::kChi2Distance:
      for_each_aligned(a, b, [&](double, double x, double y) {
        if (x + y > 0) acc += (x - y) * (x - y) / (x + y);
      });
      return 0.5 * acc;
    case Metric::kHellinger:
      // The sum-of-squares form, not sqrt(1 - sum sqrt(ab)), which cancels for close laws.
      for_each_aligned(a, b, [&](double, double x, double y) {
        const double d = std::sqrt(x) - std::sqrt(y);
        acc += d * d;
      });
      return std::min(1.0, std::sqrt(0.5 * acc));
    case Metric::kKL:
      for_each_aligned(a, b, [&](double, double x, double y) { acc += kl_term(x, y); });
      return std::max(0.0, acc);
    case Metric::kJS:
      for_each_aligned(a, b, [&](double, double x, double y) {
        const double m = 0.5 * (x + y);
        acc += 0.5 * kl_term(x, m) + 0.5 * kl_term(y, m);
      });
      return std::clamp(acc, 0.0, std::log(2.0));
    case Metric::kW1:
    case Metric::kKS: {
      double fa = 0.0, fb = 0.0, prev_x = 0.0, w1 = 0.0, ks = 0.0;
      bool first = true;
      for_each_aligned(a, b, [&](double x, double pa, double pb) {
        if (!first) w1 += std::abs(fa - fb) * (x - prev_x);
        first = false;
        fa += pa;
        fb += pb;
        ks = std::max(ks, std::abs(fa - fb));
        prev_x = x;
      });
      return metric == Metric::kW1 ? w1 : std::min(1.0, ks);
    }
  }
  throw std::logic_error("unknown metric");
}

}  // namespace glintlab
