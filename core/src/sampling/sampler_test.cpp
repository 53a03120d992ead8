// The direction-sampler harness's numerical core (docs/math/sampling.md; header
// glintlab/sampling/sampler_test.hpp).
#include "glintlab/sampling/sampler_test.hpp"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/chi2.hpp"

namespace glintlab::sampling {

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr char kWhere[] = "sampler_test";
constexpr double kPeakRatio = 4.0;
// ... and only while that peak could hold this many samples: finer peaks cannot move a count.
constexpr double kPeakCount = 0.005;
constexpr double kLostWeight = 0.05;  // share of the significance given to the lost-sample test

void check_tolerances(const BinOptions& o) {
  if (!(o.rel_tol >= 0.0) || !std::isfinite(o.rel_tol))
    throw_invalid(kWhere, "rel_tol", o.rel_tol, "a finite number >= 0");
  if (!(o.shift_tol >= 0.0) || !std::isfinite(o.shift_tol))
    throw_invalid(kWhere, "cubature_tol", o.shift_tol, "a finite number >= 0");
  if (!(o.min_expected > 0.0) || !std::isfinite(o.min_expected))
    throw_invalid(kWhere, "min_expected", o.min_expected, "a finite number > 0");
}

// Azimuth as a fraction of a turn in [0, 1).
double turn(double x, double y) {
  double t = std::atan2(y, x) / kTwoPi;
  if (t < 0.0) t += 1.0;
  return t >= 1.0 ? 0.0 : t;
}

// Genz & Malik (1980), the degree-7 rule for n = 2 on [-1, 1]^2 with weights normalised to sum to 1
// (multiply by the area), and the degree-5 rule on the same nodes (its weight on the 2^n corner
// nodes is 0). Generators: the centre; +-l2 and +-l3 on each axis; (+-l4, +-l4); (+-l5, +-l5).
const double kL2 = std::sqrt(9.0 / 70.0), kL3 = std::sqrt(9.0 / 10.0), kL4 = std::sqrt(9.0 / 10.0),
             kL5 = std::sqrt(9.0 / 19.0);
// n = 2: w1 = (12824 - 9120 n + 400 n^2) / 19683, w2 = 980 / 6561, w3 = (1820 - 400 n) / 19683,
// w4 = 200 / 19683, w5 = 6859 / 19683 / 2^n; degree 5: (729 - 950 n + 50 n^2) / 729, 245 / 486,
// (265 - 100 n) / 1458, 25 / 729.
constexpr double kW7[5] = {-3816.0 / 19683.0, 980.0 / 6561.0, 1020.0 / 19683.0, 200.0 / 19683.0,
                           6859.0 / 19683.0 / 4.0};
constexpr double kW5[4] = {-971.0 / 729.0, 245.0 / 486.0, 65.0 / 1458.0, 25.0 / 729.0};

}  // namespace

Domain parse_domain(std::string_view name) {
  if (name == "hemisphere") return Domain::hemisphere;
  if (name == "sphere") return Domain::sphere;
  if (name == "disk") return Domain::disk;
  if (name == "square") return Domain::square;
  throw_invalid(kWhere, "domain", name, "\"hemisphere\", \"sphere\", \"disk\" or \"square\"");
}

const char* domain_name(Domain d) {
  switch (d) {
    case Domain::hemisphere: return "hemisphere";
    case Domain::sphere: return "sphere";
    case Domain::disk: return "disk";
    case Domain::square: return "square";
  }
  return "";
}

int domain_dim(Domain d) { return d == Domain::hemisphere || d == Domain::sphere ? 3 : 2; }

double domain_measure(Domain d) {
  switch (d) {
    case Domain::hemisphere: return kTwoPi;      // dw = dz dphi, z = s, phi = 2 pi t
    case Domain::sphere: return 2.0 * kTwoPi;    // z = 2 s - 1
    case Domain::disk: return std::numbers::pi;  // dA = r dr dphi = d(r^2) dphi / 2, r^2 = s
    case Domain::square: return 1.0;
  }
  return 1.0;
}

void to_square(Domain d, const double* points, std::size_t count, double unit_tol, double* s, double* t,
               std::uint8_t* lost) {
  const int dim = domain_dim(d);
  for (std::size_t i = 0; i < count; ++i) {
    const double* p = points + dim * i;
    bool bad = false;
    for (int k = 0; k < dim; ++k) bad = bad || !std::isfinite(p[k]);
    double si = -1.0, ti = -1.0;
    if (!bad) {
      switch (d) {
        case Domain::hemisphere:
        case Domain::sphere: {
          const double norm = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
          if (!(std::abs(norm - 1.0) <= unit_tol) || (d == Domain::hemisphere && p[2] < 0.0)) {
            bad = true;
            break;
          }
          const double z = std::clamp(p[2] / norm, -1.0, 1.0);
          si = d == Domain::hemisphere ? z : 0.5 * (z + 1.0);
          ti = turn(p[0], p[1]);
          break;
        }
        case Domain::disk: {
          const double r2 = p[0] * p[0] + p[1] * p[1];
          if (r2 > 1.0) {
            bad = true;
            break;
          }
          si = r2;
          ti = turn(p[0], p[1]);
          break;
        }
        case Domain::square:
          if (!(p[0] >= 0.0 && p[0] <= 1.0 && p[1] >= 0.0 && p[1] <= 1.0)) {
            bad = true;
            break;
          }
          si = p[0];
          ti = p[1];
          break;
      }
    }
    s[i] = bad ? -1.0 : si;
    t[i] = bad ? -1.0 : ti;
    lost[i] = bad ? 1 : 0;
  }
}

void from_square(Domain d, double s, double t, double* p) {
  const double phi = kTwoPi * t;
  switch (d) {
    case Domain::hemisphere:
    case Domain::sphere: {
      const double z = d == Domain::hemisphere ? s : 2.0 * s - 1.0;
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      p[0] = r * std::cos(phi);
      p[1] = r * std::sin(phi);
      p[2] = z;
      return;
    }
    case Domain::disk: {
      const double r = std::sqrt(std::max(0.0, s));
      p[0] = r * std::cos(phi);
      p[1] = r * std::sin(phi);
      return;
    }
    case Domain::square:
      p[0] = s;
      p[1] = t;
      return;
  }
}

void genz_malik_nodes(const Rect& r, double* st) {
  const double cs = r.s0 + 0.5 * r.ws, ct = r.t0 + 0.5 * r.wt, hs = 0.5 * r.ws, ht = 0.5 * r.wt;
  int k = 0;
  auto put = [&](double a, double b) {
    st[2 * k] = cs + hs * a;
    st[2 * k + 1] = ct + ht * b;
    ++k;
  };
  put(0, 0);
  for (double l : {kL2, kL3}) {
    put(l, 0);
    put(-l, 0);
    put(0, l);
    put(0, -l);
  }
  put(kL4, kL4);
  put(kL4, -kL4);
  put(-kL4, kL4);
  put(-kL4, -kL4);
  put(kL5, kL5);
  put(kL5, -kL5);
  put(-kL5, kL5);
  put(-kL5, -kL5);
}

void genz_malik_integrate(const Rect& r, const double* f, double& integral, double& error) {
  const double c = f[0];
  const double s2 = f[1] + f[2] + f[3] + f[4], s3 = f[5] + f[6] + f[7] + f[8];
  const double s4 = f[9] + f[10] + f[11] + f[12], s5 = f[13] + f[14] + f[15] + f[16];
  const double area = r.ws * r.wt;
  const double i7 = kW7[0] * c + kW7[1] * s2 + kW7[2] * s3 + kW7[3] * s4 + kW7[4] * s5;
  const double i5 = kW5[0] * c + kW5[1] * s2 + kW5[2] * s3 + kW5[3] * s4;
  // A density is >= 0: a negative degree-7 value (a spike seen by one node with a negative-weight
  // centre) is no integral; the error estimate then covers at least its size.
  integral = area * std::max(i7, 0.0);
  error = area * std::max(std::abs(i7 - i5), std::max(-i7, 0.0));
}

Bins::Bins(Domain d, const BinOptions& options, const double* pilot_s, const double* pilot_t, std::size_t pilot_count,
           const double* pilot_pdf)
    : domain_(d), opt_(options) {
  if (!(opt_.total >= 1.0) || !std::isfinite(opt_.total)) throw_invalid(kWhere, "samples", opt_.total, "a number >= 1");
  if (!(opt_.target > 0.0) || !std::isfinite(opt_.target))
    throw_invalid(kWhere, "target", opt_.target, "a finite number > 0");
  check_tolerances(opt_);
  if (opt_.max_depth < 0 || opt_.max_depth > 30)
    throw_invalid(kWhere, "max_depth", opt_.max_depth, "an integer in [0, 30]");
  ps_.assign(pilot_s, pilot_s + pilot_count);
  pt_.assign(pilot_t, pilot_t + pilot_count);
  if (pilot_pdf) {
    pq_.resize(pilot_count);
    for (std::size_t i = 0; i < pilot_count; ++i) {
      if (!(pilot_pdf[i] >= 0.0) || !std::isfinite(pilot_pdf[i]))
        throw_invalid(kWhere, "pdf(pilot point)", pilot_pdf[i], "a finite density >= 0");
      pq_[i] = domain_measure(d) * pilot_pdf[i];
    }
  }
  // Lost pilot points are not in the arrays but count in the pilot's size.
  pilot_drawn_ = std::max(opt_.pilot_drawn, static_cast<double>(pilot_count));
  pilot_scale_ = pilot_drawn_ > 0 ? opt_.total / pilot_drawn_ : 0.0;
  Node root;
  tree_.push_back(root);
  tree_rect_.push_back({0.0, 0.0, 1.0, 1.0});
  tree_val_.push_back(0.0);
  tree_err_.push_back(0.0);
  tree_top_.push_back(0.0);
  tree_depth_.push_back(0);
  pending_.push_back({{0.0, 0.0, 1.0, 1.0}, 0, 0});
  pilot_range_.push_back({0, pilot_count});
  emit_nodes();
}

Bins::Bins(Domain d, const BinOptions& options, std::vector<double> s_edges, std::vector<double> t_edges)
    : domain_(d), opt_(options), tree_phase_(false), grid_(true), s_edges_(std::move(s_edges)),
      t_edges_(std::move(t_edges)) {
  init_grid();
  for (std::size_t b = 0; b < leaves_.size(); ++b) pending_.push_back({leaves_[b], 0, static_cast<std::int64_t>(b)});
  emit_nodes();
}

Bins::Bins(const Bins& resolved, std::vector<double> s_edges, std::vector<double> t_edges)
    : domain_(resolved.domain_), opt_(resolved.opt_), tree_phase_(false), grid_(true), s_edges_(std::move(s_edges)),
      t_edges_(std::move(t_edges)) {
  if (!resolved.done()) throw std::logic_error("sampler_test: bins are not complete (pdf values pending)");
  init_grid();
  // Index of the grid cell along one axis that holds x (edges 0 = e_0 < ... < e_n = 1): the number of
  // inner edges <= x; and the last cell a cell ending at x1 overlaps: the number of inner edges < x1.
  auto first = [](const std::vector<double>& e, double x) {
    return static_cast<std::size_t>(std::upper_bound(e.begin() + 1, e.end() - 1, x) - (e.begin() + 1));
  };
  auto last = [](const std::vector<double>& e, double x1) {
    return static_cast<std::size_t>(std::lower_bound(e.begin() + 1, e.end() - 1, x1) - (e.begin() + 1));
  };
  const std::size_t nt = t_edges_.size() - 1;
  for (const auto& cells : resolved.sub_)
    for (const SubCell& c : cells) {
      const double s1 = c.r.s0 + c.r.ws, t1 = c.r.t0 + c.r.wt;
      const std::size_t i0 = first(s_edges_, c.r.s0), i1 = last(s_edges_, s1);
      const std::size_t j0 = first(t_edges_, c.r.t0), j1 = last(t_edges_, t1);
      if (i0 == i1 && j0 == j1) {  // inside one grid cell: its integral, error and peak as they are
        sub_[i0 * nt + j0].push_back(c);
        continue;
      }
      for (std::size_t i = i0; i <= i1; ++i)  // cut along the grid's edges; the pieces integrated afresh
        for (std::size_t j = j0; j <= j1; ++j) {
          const double a = std::max(c.r.s0, s_edges_[i]), b = std::max(c.r.t0, t_edges_[j]);
          const Rect piece{a, b, std::min(s1, s_edges_[i + 1]) - a, std::min(t1, t_edges_[j + 1]) - b};
          if (piece.ws > 0.0 && piece.wt > 0.0)
            pending_.push_back({piece, c.depth, static_cast<std::int64_t>(i * nt + j)});
        }
    }
  if (pending_.empty()) finish_refine_round({}, {}, {});  // nothing cut: straight to the refinement's plan
  if (!pending_.empty()) emit_nodes();
}

void Bins::init_grid() {
  if (!(opt_.total >= 1.0) || !std::isfinite(opt_.total)) throw_invalid(kWhere, "samples", opt_.total, "a number >= 1");
  check_tolerances(opt_);
  for (const auto* edges : {&s_edges_, &t_edges_}) {
    if (edges->size() < 2 || edges->front() != 0.0 || edges->back() != 1.0 ||
        !std::is_sorted(edges->begin(), edges->end()) ||
        std::adjacent_find(edges->begin(), edges->end()) != edges->end())
      throw_invalid_message("sampler_test: grid edges must increase strictly from 0 to 1");
  }
  for (std::size_t i = 0; i + 1 < s_edges_.size(); ++i)
    for (std::size_t j = 0; j + 1 < t_edges_.size(); ++j) {
      leaves_.push_back({s_edges_[i], t_edges_[j], s_edges_[i + 1] - s_edges_[i], t_edges_[j + 1] - t_edges_[j]});
      depth_.push_back(0);
    }
  integral_.assign(leaves_.size(), 0.0);
  error_.assign(leaves_.size(), 0.0);
  sub_.assign(leaves_.size(), {});
}

void Bins::emit_nodes() {
  const int dim = domain_dim(domain_);
  nodes_.assign(pending_.size() * kGenzMalikNodes * dim, 0.0);
  detail::parallel_chunks(pending_.size(), 256, 4096, [&](std::size_t i0, std::size_t i1) {
    double st[2 * kGenzMalikNodes];
    for (std::size_t i = i0; i < i1; ++i) {
      genz_malik_nodes(pending_[i].r, st);
      for (int k = 0; k < kGenzMalikNodes; ++k)
        from_square(domain_, st[2 * k], st[2 * k + 1], &nodes_[(i * kGenzMalikNodes + k) * dim]);
    }
  });
}

void Bins::supply(const double* values, std::size_t count) {
  if (pending_.empty()) throw std::logic_error("sampler_test: no pdf values are pending");
  if (count != pending_.size() * kGenzMalikNodes)
    throw_invalid_message("sampler_test: pdf returned " + std::to_string(count) + " values for " +
                          std::to_string(pending_.size() * kGenzMalikNodes) + " points");
  const int dim = domain_dim(domain_);
  for (std::size_t i = 0; i < count; ++i)
    if (!(values[i] >= 0.0) || !std::isfinite(values[i])) {
      std::string at = "(";
      for (int k = 0; k < dim; ++k) at += (k ? ", " : "") + format_value(nodes_[i * dim + k]);
      throw_invalid(kWhere, "pdf" + at + ")", values[i], "a finite density >= 0");
    }
  evaluations_ += count;
  ++rounds_;
  const double measure = domain_measure(domain_);
  std::vector<double> value(pending_.size()), err(pending_.size()), top(pending_.size());
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    double f[kGenzMalikNodes];
    for (int k = 0; k < kGenzMalikNodes; ++k) f[k] = measure * values[i * kGenzMalikNodes + k];
    genz_malik_integrate(pending_[i].r, f, value[i], err[i]);
    top[i] = *std::max_element(f, f + kGenzMalikNodes);
  }
  if (tree_phase_)
    finish_tree_round(value, err, top);
  else
    finish_refine_round(value, err, top);
  nodes_.clear();
  if (!pending_.empty()) emit_nodes();
}

void Bins::finish_tree_round(const std::vector<double>& value, const std::vector<double>& err,
                             const std::vector<double>& top) {
  std::vector<Task> next;
  std::vector<std::pair<std::size_t, std::size_t>> next_range;
  const bool budget = evaluations_ + 4 * kGenzMalikNodes * pending_.size() <= opt_.max_nodes;
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Task& task = pending_[i];
    const auto [p0, p1] = pilot_range_[i];
    tree_val_[task.node] = value[i];
    tree_err_[task.node] = err[i];
    tree_top_[task.node] = top[i];
    const double expected = opt_.total * value[i];
    const double pilot = pilot_scale_ * static_cast<double>(p1 - p0);
    // A cell the cubature cannot yet resolve (error comparable to its mass) splits too: a spike
    // between the nodes shows only as a large |I7 - I5|.
    const bool heavy = std::max({expected, pilot, opt_.total * err[i]}) > opt_.target;
    // The pilot and the cubature disagree beyond the pilot's Poisson noise: either the cubature has not
    // seen a spike the pilot hit, or the sampler is wrong there. Splitting resolves the first and is
    // harmless for the second (it stops where cells hold too few pilot points to disagree).
    const double hits = static_cast<double>(p1 - p0), lambda = pilot_drawn_ * value[i];
    const bool discrepant = pilot_drawn_ > 0 && std::abs(hits - lambda) > 3.0 * std::sqrt(lambda) + 3.0;
    // A peak the cubature has not resolved: the pdf at a pilot point of the cell, times the cell's
    // area, far above the cell's integral (a smooth integrand stays within a few times its mean; a
    // lobe much narrower than the cell exceeds it by (cell / width)^2).
    // (The cubature's own largest node value, top, plays the same part for the integration cells of
    // each bin, after the tree: it refines the integral without multiplying the bins.)
    double peak = 0.0;
    if (!pq_.empty())
      for (std::size_t j = p0; j < p1; ++j) peak = std::max(peak, pq_[j]);
    const double reach = peak * task.r.ws * task.r.wt;  // mass the cell would hold at its peak density
    const bool peaked = reach > kPeakRatio * (value[i] + err[i]) && opt_.total * reach > kPeakCount;
    const bool can_split = task.depth < opt_.max_depth && budget;
    const bool split = task.depth < opt_.min_depth || ((heavy || discrepant || peaked) && can_split);
    if (peaked && !can_split && task.depth >= opt_.min_depth) stuck_.emplace_back(task.node, peak);
    if (!split) continue;
    // Children in the order (s low, t low), (s high, t low), (s low, t high), (s high, t high); the
    // pilot points of the cell are partitioned in place into the same order.
    const double hs = 0.5 * task.r.ws, ht = 0.5 * task.r.wt;
    const double ms = task.r.s0 + hs, mt = task.r.t0 + ht;
    std::vector<std::size_t> idx(p1 - p0);
    for (std::size_t k = 0; k < idx.size(); ++k) idx[k] = p0 + k;
    auto quadrant = [&](std::size_t k) { return (ps_[k] >= ms ? 1 : 0) + (pt_[k] >= mt ? 2 : 0); };
    std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return quadrant(a) < quadrant(b); });
    std::vector<double> s2(idx.size()), t2(idx.size()), q2(pq_.empty() ? 0 : idx.size());
    std::size_t bounds[5] = {p0, p0, p0, p0, p0};
    for (std::size_t j = 0; j < idx.size(); ++j) {
      s2[j] = ps_[idx[j]];
      t2[j] = pt_[idx[j]];
      if (!pq_.empty()) q2[j] = pq_[idx[j]];
      ++bounds[quadrant(idx[j]) + 1];
    }
    for (int q = 1; q < 5; ++q) bounds[q] += bounds[q - 1] - p0;
    const auto at = static_cast<std::ptrdiff_t>(p0);
    std::copy(s2.begin(), s2.end(), ps_.begin() + at);
    std::copy(t2.begin(), t2.end(), pt_.begin() + at);
    std::copy(q2.begin(), q2.end(), pq_.begin() + at);
    const auto first = static_cast<std::int64_t>(tree_.size());
    tree_[task.node].child = first;
    for (int q = 0; q < 4; ++q) {
      const Rect r{task.r.s0 + (q & 1 ? hs : 0.0), task.r.t0 + (q & 2 ? ht : 0.0), hs, ht};
      tree_.push_back(Node{});
      tree_rect_.push_back(r);
      tree_val_.push_back(0.0);
      tree_err_.push_back(0.0);
      tree_top_.push_back(0.0);
      tree_depth_.push_back(task.depth + 1);
      next.push_back({r, task.depth + 1, first + q});
      next_range.push_back({bounds[q], bounds[q + 1]});
    }
  }
  pending_ = std::move(next);
  pilot_range_ = std::move(next_range);
  if (pending_.empty()) start_refinement();
}

void Bins::start_refinement() {
  tree_phase_ = false;
  ps_.clear();
  ps_.shrink_to_fit();
  pt_.clear();
  pt_.shrink_to_fit();
  pq_.clear();
  pq_.shrink_to_fit();
  // Leaves numbered depth first, children in quadrant order (a Z-order curve): consecutive bins are
  // neighbours, so merging consecutive low-expectation bins merges nearby cells.
  std::vector<std::int64_t> stack{0};
  while (!stack.empty()) {
    const std::int64_t n = stack.back();
    stack.pop_back();
    if (tree_[n].child < 0) {
      tree_[n].leaf = static_cast<std::int64_t>(leaves_.size());
      leaves_.push_back(tree_rect_[n]);
      depth_.push_back(tree_depth_[n]);
      integral_.push_back(tree_val_[n]);
      error_.push_back(tree_err_[n]);
      sub_.push_back({SubCell{tree_rect_[n], 0, tree_val_[n], tree_err_[n], tree_top_[n]}});
    } else {
      for (int q = 3; q >= 0; --q) stack.push_back(tree_[n].child + q);
    }
  }
  // A peak the tree could not split down to: its integration cell starts with the pilot's peak as its
  // largest value, so that the refinement's own peak test splits it (a finer cell may resolve it).
  for (auto& [node, peak] : stuck_) {
    node = tree_[node].leaf;
    SubCell& c = sub_[node].front();
    c.top = std::max(c.top, peak);
  }
  plan_refinement();
}

void Bins::global_shift(std::vector<double>& weight) {
  // The statistic X^2 = sum_g (o_g - e_g)^2 / e_g is computed with e_g = N m_g, while the counts have
  // mean e_g + d_g, |d_g| <= D_g (the cubature error in samples, summed over the group's bins). Its
  // mean then moves by sum_g [d_g + d_g^2] / e_g to first and second order (the variance term
  // (e_g + d_g) / e_g and the squared offset d_g^2 / e_g): at most B = sum_g (D_g + D_g^2) / e_g.
  // The groups are the statistic's own (merge_starts on the current expected counts), since merging
  // adds errors as well as expectations.
  const std::size_t m = leaves_.size();
  std::vector<double> expected(m);
  for (std::size_t b = 0; b < m; ++b) expected[b] = opt_.total * integral_[b];
  const auto starts = merge_starts(expected.data(), m, opt_.min_expected);
  weight.assign(m, 0.0);
  double bound = 0.0;
  for (std::size_t g = 0; g < starts.size(); ++g) {
    const std::size_t end = g + 1 < starts.size() ? starts[g + 1] : m;
    double e = 0.0, d = 0.0;
    for (std::size_t b = starts[g]; b < end; ++b) {
      e += expected[b];
      d += opt_.total * error_[b];
    }
    // A group expecting almost nothing (the pdf's mass not yet found there) is weighed as if it expected
    // min_expected: its error then still counts, without dividing by zero.
    e = std::max(e, opt_.min_expected);
    bound += (d + d * d) / e;
    for (std::size_t b = starts[g]; b < end; ++b) weight[b] = (1.0 + 2.0 * d) / e;  // dB / dD_g
  }
  shift_bound_ = bound;
  mass_error_ = 0.0;
  for (std::size_t b = 0; b < m; ++b) mass_error_ += opt_.total * error_[b];
  mass_limit_ = opt_.shift_tol * std::sqrt(opt_.total);
  const double dof = std::max<double>(1.0, static_cast<double>(starts.size()) - 1.0);
  shift_limit_ = opt_.shift_tol * std::sqrt(2.0 * dof);
}

void Bins::plan_refinement() {
  pending_.clear();
  unconverged_ = 0;
  const bool per_bin = opt_.rel_tol > 0.0, global = opt_.shift_tol > 0.0;
  std::vector<double> weight;
  global_shift(weight);  // reported even while the global rule is off
  // Which integration cells to split:
  // - per-bin rule: in a bin whose error exceeds its tolerance, every cell holding more than an equal
  //   share of that tolerance (the largest always does, so each round progresses);
  // - global rule: while the bound on the statistic's shift exceeds its limit, the cells with the
  //   largest share of the bound (their error times the derivative of the bound in their group's
  //   error), most first, until those shares cover the excess plus half the limit (as if splitting
  //   removed their error: a cell on a jump of the pdf only halves it, so a few rounds follow);
  // - either way, every cell whose largest node value times its area is far above its integral (a peak
  //   the nodes only grazed, whose |I7 - I5| cannot be trusted), while that peak could matter for a count.
  std::vector<std::pair<std::size_t, std::size_t>> splits;  // (bin, cell)
  std::vector<std::vector<bool>> drop(leaves_.size());
  auto mark = [&](std::size_t b, std::size_t k) {
    if (drop[b].empty()) drop[b].assign(sub_[b].size(), false);
    if (drop[b][k]) return;
    drop[b][k] = true;
    splits.emplace_back(b, k);
  };
  for (std::size_t b = 0; b < leaves_.size(); ++b) {
    const double tol = opt_.rel_tol * std::sqrt(std::max(opt_.total * integral_[b], 1.0));
    const bool over = per_bin && opt_.total * error_[b] > tol;
    const auto& cells = sub_[b];
    const double share = tol / static_cast<double>(cells.size());
    bool any = false;
    for (std::size_t k = 0; k < cells.size(); ++k) {
      const SubCell& c = cells[k];
      const double reach = c.top * c.r.ws * c.r.wt;
      const bool grazed = reach > kPeakRatio * (c.value + c.err) && opt_.total * reach > kPeakCount;
      if (((over && opt_.total * c.err > share) || grazed) && c.depth < opt_.max_sub_depth) {
        mark(b, k);
        any = any || over;
      }
    }
    if (over && !any) ++unconverged_;
  }
  // Greedy cover: the cells with the largest share of an excess quantity (share = its error times
  // `scale` of its bin), most first, until their shares add up to `goal`.
  auto cover = [&](const std::vector<double>& scale, double goal) {
    struct Share {
      double v;
      std::size_t b, k;
    };
    std::vector<Share> shares;
    for (std::size_t b = 0; b < leaves_.size(); ++b)
      for (std::size_t k = 0; k < sub_[b].size(); ++k)
        if (sub_[b][k].depth < opt_.max_sub_depth && sub_[b][k].err > 0.0)
          shares.push_back({scale[b] * opt_.total * sub_[b][k].err, b, k});
    // Largest share first; ties in (bin, cell) order, so the plan does not depend on the sort.
    std::sort(shares.begin(), shares.end(), [](const Share& x, const Share& y) {
      return x.v != y.v ? x.v > y.v : (x.b != y.b ? x.b < y.b : x.k < y.k);
    });
    double covered = 0.0;
    for (const auto& sh : shares) {
      if (covered >= goal) break;
      mark(sh.b, sh.k);
      covered += sh.v;
    }
  };
  if (global && shift_bound_ > shift_limit_) cover(weight, shift_bound_ - 0.5 * shift_limit_);
  // The total mass's error, in samples, is the width of the range the lost-sample test accepts
  // (docs/math/sampling.md#lost-sample-bin): the global rule also keeps it within shift_tol sqrt(N), so
  // that a loss of a small fraction of the samples stays visible.
  // The mass's splits are wanted, not required (the lost-sample test stays valid whatever its range;
  // only its power depends on it): a round that would exceed the budget drops them first.
  const std::size_t required = splits.size();
  // They come after the statistic's: only once the shift is within its limit, so that a budget spent on
  // the mass never leaves the chi-square's rule unmet.
  if (global && shift_bound_ <= shift_limit_ && mass_error_ > mass_limit_)
    cover(std::vector<double>(leaves_.size(), 1.0), mass_error_ - 0.5 * mass_limit_);
  // Their own allowance: as many evaluations again as the bins and the statistic's rule took (at a jump
  // of the pdf the mass converges only to first order, and would otherwise take the whole budget).
  if (global && shift_bound_ <= shift_limit_ && shift_met_at_ == 0)
    shift_met_at_ = std::max<std::size_t>(evaluations_, 1);
  const std::size_t mass_budget = std::min(opt_.max_nodes, 2 * shift_met_at_);
  if (splits.size() > required && evaluations_ + 4 * splits.size() * kGenzMalikNodes > mass_budget) {
    for (std::size_t i = required; i < splits.size(); ++i) drop[splits[i].first][splits[i].second] = false;
    splits.resize(required);
  }
  if (splits.empty()) return;
  if (evaluations_ + 4 * splits.size() * kGenzMalikNodes > opt_.max_nodes) {
    // Out of budget: keep the integrals as they are; every bin still above its tolerance is counted
    // (and the global bound stays above its limit, which the caller sees).
    unconverged_ = 0;
    if (per_bin)
      for (std::size_t b = 0; b < leaves_.size(); ++b)
        if (opt_.total * error_[b] > opt_.rel_tol * std::sqrt(std::max(opt_.total * integral_[b], 1.0))) ++unconverged_;
    return;
  }
  for (const auto& [b, k] : splits) {
    const SubCell c = sub_[b][k];
    const double hs = 0.5 * c.r.ws, ht = 0.5 * c.r.wt;
    for (int q = 0; q < 4; ++q)
      pending_.push_back({{c.r.s0 + (q & 1 ? hs : 0.0), c.r.t0 + (q & 2 ? ht : 0.0), hs, ht},
                          c.depth + 1,
                          static_cast<std::int64_t>(b)});
  }
  for (std::size_t b = 0; b < leaves_.size(); ++b) {
    if (drop[b].empty()) continue;
    std::vector<SubCell> kept;
    for (std::size_t k = 0; k < sub_[b].size(); ++k)
      if (!drop[b][k]) kept.push_back(sub_[b][k]);
    sub_[b] = std::move(kept);
  }
}

void Bins::finish_refine_round(const std::vector<double>& value, const std::vector<double>& err,
                               const std::vector<double>& top) {
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Task& task = pending_[i];
    sub_[task.node].push_back(SubCell{task.r, task.depth, value[i], err[i], top[i]});
  }
  // Sums in a fixed order (the cells' order in each bin), whatever the threads.
  for (std::size_t b = 0; b < leaves_.size(); ++b) {
    double v = 0.0, e = 0.0;
    for (const auto& c : sub_[b]) {
      v += c.value;
      e += c.err;
    }
    integral_[b] = v;
    error_[b] = e;
  }
  plan_refinement();
}

std::pair<std::size_t, double> Bins::unresolved() const {
  std::pair<std::size_t, double> out{0, 0.0};
  if (!done()) return out;
  for (const auto& [b, peak] : stuck_) {
    const double reach = peak * leaves_[b].ws * leaves_[b].wt;
    if (reach > kPeakRatio * (integral_[b] + error_[b]) && opt_.total * reach > kPeakCount) {
      ++out.first;
      out.second += opt_.total * reach;
    }
  }
  return out;
}

std::int64_t Bins::descend(double s, double t) const {
  if (grid_) {
    const auto i = std::upper_bound(s_edges_.begin() + 1, s_edges_.end() - 1, s) - (s_edges_.begin() + 1);
    const auto j = std::upper_bound(t_edges_.begin() + 1, t_edges_.end() - 1, t) - (t_edges_.begin() + 1);
    return static_cast<std::int64_t>(i) * static_cast<std::int64_t>(t_edges_.size() - 1) + j;
  }
  std::int64_t n = 0;
  double s0 = 0.0, t0 = 0.0, w = 1.0;
  while (tree_[n].child >= 0) {
    w *= 0.5;
    const int q = (s >= s0 + w ? 1 : 0) + (t >= t0 + w ? 2 : 0);
    if (q & 1) s0 += w;
    if (q & 2) t0 += w;
    n = tree_[n].child + q;
  }
  return tree_[n].leaf;
}

void Bins::locate(const double* s, const double* t, std::size_t count, std::int64_t* bin) const {
  if (!done()) throw std::logic_error("sampler_test: bins are not complete (pdf values pending)");
  for (std::size_t i = 0; i < count; ++i) bin[i] = s[i] < 0.0 ? -1 : descend(s[i], t[i]);
}

void Bins::count(Domain d, const double* points, std::size_t n, double unit_tol, std::vector<double>& counts,
                 double& lost) const {
  if (!done()) throw std::logic_error("sampler_test: bins are not complete (pdf values pending)");
  if (d != domain_) throw_invalid_message("sampler_test: points of another domain");
  counts.resize(leaves_.size(), 0.0);
  const int dim = domain_dim(d);
  constexpr std::size_t kChunk = 1 << 16;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  // Integer counts per chunk, added in chunk order: the totals are exact whatever the threads.
  std::vector<std::vector<std::uint32_t>> partial(chunks);
  std::vector<std::uint32_t> lost_partial(chunks, 0);
  detail::parallel_chunks(n, kChunk, 2 * kChunk, [&](std::size_t i0, std::size_t i1) {
    const std::size_t c = i0 / kChunk, m = i1 - i0;
    std::vector<double> s(m), t(m);
    std::vector<std::uint8_t> bad(m);
    to_square(d, points + i0 * dim, m, unit_tol, s.data(), t.data(), bad.data());
    auto& out = partial[c];
    out.assign(leaves_.size(), 0);
    std::uint32_t l = 0;
    for (std::size_t k = 0; k < m; ++k) {
      if (bad[k]) {
        ++l;
        continue;
      }
      ++out[static_cast<std::size_t>(descend(s[k], t[k]))];
    }
    lost_partial[c] = l;
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    for (std::size_t b = 0; b < leaves_.size(); ++b) counts[b] += partial[c][b];
    lost += lost_partial[c];
  }
}

ChiSquare chi_square(const std::vector<double>& observed, const std::vector<double>& integral,
                     const std::vector<double>& error, double lost, double total, double min_expected) {
  if (observed.size() != integral.size() || error.size() != integral.size())
    throw_invalid_message("sampler_test: observed, integral and error differ in length");
  if (!(min_expected > 0.0) || !std::isfinite(min_expected))
    throw_invalid(kWhere, "min_expected", min_expected, "a finite number > 0");
  ChiSquare r;
  const std::size_t m = integral.size();
  std::vector<double> expected(m);
  double mass = 0.0, mass_err = 0.0;
  for (std::size_t b = 0; b < m; ++b) {
    expected[b] = total * integral[b];
    mass += integral[b];
    mass_err += error[b];
  }
  r.starts = merge_starts(expected.data(), m, min_expected);
  for (std::size_t g = 0; g < r.starts.size(); ++g) {
    const std::size_t end = g + 1 < r.starts.size() ? r.starts[g + 1] : m;
    double o = 0.0, e = 0.0;
    for (std::size_t b = r.starts[g]; b < end; ++b) {
      o += observed[b];
      e += expected[b];
    }
    r.observed.push_back(o);
    r.expected.push_back(e);
  }
  // The lost bin: what the pdf does not integrate to. It is never merged (it is no neighbour of any
  // cell) and never a chi-square bin: its expected count N (1 - M) is only known within the cubature's
  // error N e of M, and the per-bin errors, each far below its own bin's noise, add up in M. So the lost
  // count is tested exactly against every expectation the error allows: too many lost samples against
  // the largest, lambda_hi = N (1 - M + e), too few against the smallest, lambda_lo = N (1 - M - e) (a pdf
  // that leaves mass the sampler never loses), two-sided.
  r.lost_observed = lost;
  r.lost_expected = std::max(0.0, total * (1.0 - mass));
  const double hi_raw = total * (1.0 - mass + mass_err);
  const double hi = std::max(0.0, hi_raw), lo = total * std::max(0.0, 1.0 - mass - mass_err);
  const double p_many = lost <= 0.0 ? 1.0 : (hi > 0.0 ? boost::math::gamma_p(lost, hi) : 0.0);  // P(X >= lost)
  // P(X <= lost). A pdf whose mass exceeds 1 beyond its error (hi_raw < 0) claims -hi_raw more samples
  // inside the domain than were drawn: as a bin expecting -hi_raw samples that received none, P =
  // exp(hi_raw). So the test is two-sided about 1 (docs/math/sampling.md#lost-sample-bin): a mass of
  // 1.0013 +- 0.00024 fails as 0.9975 does.
  const double p_few = lo > 0.0 ? boost::math::gamma_q(lost + 1.0, lo) : std::exp(std::min(hi_raw, 0.0));
  r.pvalue_lost = std::min(1.0, 2.0 * std::min(p_many, p_few));
  bool impossible = false;
  for (std::size_t k = 0; k < r.observed.size(); ++k) {
    const double d = r.observed[k] - r.expected[k];
    if (r.expected[k] > 0.0)
      r.statistic += d * d / r.expected[k];
    else if (r.observed[k] > 0.0)
      impossible = true;
  }
  r.dof = static_cast<int>(r.observed.size()) - 1;
  if (impossible) {
    r.statistic = std::numeric_limits<double>::infinity();
    r.pvalue_chi2 = 0.0;
    r.note = "samples fall where the pdf has no mass";
  } else if (r.dof < 1) {
    r.dof = 0;
    r.pvalue_chi2 = std::numeric_limits<double>::quiet_NaN();
    r.note = "no power: all " + format_value(total) +
             " samples merge into one bin of expected count >= " + format_value(min_expected) +
             "; the test cannot reject (p-value NaN); draw more samples";
  } else {
    const boost::math::chi_squared_distribution<double> chi2(r.dof);
    r.pvalue_chi2 = boost::math::cdf(boost::math::complement(chi2, r.statistic));
  }
  if (std::isnan(r.pvalue_chi2)) {
    r.pvalue = r.pvalue_lost < 1.0 ? r.pvalue_lost : r.pvalue_chi2;
  } else {
    // Two tests, one verdict: weighted Bonferroni, 95 % of the significance to the chi-square and 5 %
    // to the lost samples (fixed in advance, so the combination stays valid). An equal split (Sidak)
    // would double every p-value of a correct sampler, whose lost test almost always gives 1; 5 % still
    // rejects any loss of more than a couple of samples the pdf does not explain.
    r.pvalue = std::min({1.0, r.pvalue_chi2 / (1.0 - kLostWeight), r.pvalue_lost / kLostWeight});
  }
  return r;
}

}  // namespace glintlab::sampling
