// Distances between two discrete distributions (docs/math/metrics.md). Supports are aligned by exact value;
// a sample set enters as its empirical distribution (Distribution::empirical). Real-valued outputs
// must be binned by the caller first, with the binning stated.
//
// Estimating a distance from M samples is biased upward (for TV roughly sqrt(#bins / M)): compare
// against exact pmfs where the law has one, and report Monte Carlo error otherwise.
#pragma once

#include <string>
#include <vector>

#include "glintlab/stats/distribution.hpp"

namespace glintlab {

enum class Metric {
  kTV,            // total variation: 1/2 sum |a - b|                     in [0, 1]
  kChi2Distance,  // symmetric chi-square: 1/2 sum (a - b)^2 / (a + b)    in [0, 1]
  kHellinger,     // sqrt(1/2 sum (sqrt a - sqrt b)^2)                     in [0, 1]
  kKL,            // Kullback-Leibler KL(a || b) = sum a log(a / b), nats; +inf if b = 0 where a > 0
  kJS,            // Jensen-Shannon: 1/2 KL(a || m) + 1/2 KL(b || m), m = (a + b)/2; nats, <= log 2
  kW1,            // Wasserstein-1 on the support values: integral |F_a - F_b| dx
  kKS,            // Kolmogorov-Smirnov: max |F_a - F_b|
};

Metric metric_from_name(const std::string& name);  // throws std::invalid_argument naming `metric`
std::string metric_name(Metric m);
std::vector<std::string> metric_names();

double distance(const Distribution& a, const Distribution& b, Metric metric);

}  // namespace glintlab
