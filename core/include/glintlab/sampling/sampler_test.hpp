// The numerical core of the direction-sampler harness (docs/math/sampling.md): the area-preserving
// maps of the four domains onto the unit square, the bins (an adaptive quadtree or a fixed grid over
// that square) with the expected mass of each bin by adaptive Genz-Malik cubature, the binning of
// samples, and the chi-square statistic with the lost-sample bin.
//
// The pdf is the caller's (a Python callable, a shader): the core never calls it. It hands out
// batches of cubature nodes instead (`nodes()`), the caller evaluates the pdf at all of them in one
// call and hands the values back (`supply()`), until `done()`. Every decision depends only on the
// supplied values and on the pilot points, never on threads or timing, so the bins, their integrals
// and the statistic are the same whatever the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace glintlab::sampling {

enum class Domain { hemisphere, sphere, disk, square };

Domain parse_domain(std::string_view name);
const char* domain_name(Domain d);
// Coordinates per point: 3 on the hemisphere and sphere, 2 on the disk and square.
int domain_dim(Domain d);
// Measure of the domain (steradians or area units) per unit area of the square: the constant Jacobian
// of the area-preserving map (2 pi, 4 pi, pi, 1).
double domain_measure(Domain d);

// Square coordinates (s, t) in [0, 1]^2 of `count` points (`dim` coordinates each). A point that is
// not finite, not in the domain or (hemisphere, sphere) not of unit length within `unit_tol` is lost:
// lost[i] = 1 and s, t = -1.
void to_square(Domain d, const double* points, std::size_t count, double unit_tol, double* s, double* t,
               std::uint8_t* lost);
// The point of the domain at square coordinates (s, t).
void from_square(Domain d, double s, double t, double* point);

struct BinOptions {
  double total = 1e6;      // samples the test will draw: expected count = total * integral
  double target = 500.0;   // a bin splits while its expected (or pilot-estimated) count exceeds this
  int min_depth = 2;       // quadtree depth every bin reaches (16 cells at 2)
  int max_depth = 20;      // ... and never exceeds (cell side 2^-20)
  int max_sub_depth = 12;  // extra levels of integration cells inside a bin
  double rel_tol = 0.02;   // cubature error of a bin's count must be <= rel_tol sqrt(max(expected, 1)) (0: off)
  // Global rule (0: off): the bound on the chi-square statistic's shift that the cubature errors of all
  // bins together can cause (shift_bound(), docs/math/sampling.md#cubature-error) must be
  // <= shift_tol sqrt(2 dof), dof from the bins merged as the statistic merges them (min_expected),
  // and the total mass's error in samples <= shift_tol sqrt(total) (the lost-sample test's resolution).
  double shift_tol = 0.0;
  double min_expected = 5.0;
  std::size_t max_nodes = 60'000'000;  // pdf evaluations before the cubature gives up (with a note)
  double pilot_drawn = 0.0;            // points the pilot sample drew, lost ones included (0: those passed)
};

struct Rect {
  double s0, t0, ws, wt;
};

// Bins over the unit square and their expected masses. Two constructions:
// - adaptive: a quadtree from the root, split while a cell's expected count (cubature) or the count a
//   pilot sample puts in it (scaled to `total`) exceeds `target`, while the pilot's count and the
//   cubature disagree, or while the pdf at a pilot point shows a peak the cubature has not resolved,
//   down to max_depth;
// - fixed: the grid of rectangles given by s_edges x t_edges (a (theta, phi) grid maps to one).
// Then each bin's integral is refined by splitting its own integration cells until its error meets
// rel_tol.
class Bins {
 public:
  // pilot_s, pilot_t: square coordinates of the pilot sample's points (lost ones left out);
  // pilot_pdf (optional): the pdf at those points, which flags cells whose cubature missed a peak.
  Bins(Domain d, const BinOptions& options, const double* pilot_s, const double* pilot_t, std::size_t pilot_count,
       const double* pilot_pdf = nullptr);
  Bins(Domain d, const BinOptions& options, std::vector<double> s_edges, std::vector<double> t_edges);
  // The grid s_edges x t_edges over the square of `resolved` (complete), its integration starting from
  // resolved's own integration cells: a cell inside one grid cell keeps its integral, error and largest
  // value; one across the grid's edges is cut along them and the pieces integrated afresh. So the grid
  // inherits the resolution the adaptive tree found (pilot-guided, peaks included) instead of searching
  // its wide cells for them again; then it refines by the same rules (docs/math/sampling.md#polar-rows).
  Bins(const Bins& resolved, std::vector<double> s_edges, std::vector<double> t_edges);

  bool done() const { return pending_.empty(); }
  // The points (domain coordinates, domain_dim(d) per node) where the pdf is wanted next.
  const std::vector<double>& nodes() const { return nodes_; }
  // The pdf's values at nodes(), in order; throws std::invalid_argument on a negative or non-finite value.
  void supply(const double* values, std::size_t count);

  std::size_t size() const { return leaves_.size(); }
  const std::vector<Rect>& rects() const { return leaves_; }
  const std::vector<int>& depths() const { return depth_; }
  // Integral of the pdf over each bin and its error estimate (both as probabilities, not counts).
  const std::vector<double>& integral() const { return integral_; }
  const std::vector<double>& error() const { return error_; }
  std::size_t evaluations() const { return evaluations_; }
  int rounds() const { return rounds_; }
  // Bins whose cubature error stayed above the tolerance (depth or node budget exhausted).
  std::size_t unconverged() const { return unconverged_; }
  // Global rule: sum over merged bins g of (D_g + D_g^2) / E_g, E_g the expected count and D_g the
  // cubature error in samples: a bound on how far the errors move the chi-square statistic's mean;
  // shift_limit() = shift_tol sqrt(2 dof) (0 and 0 while the rule is off or the bins are not done).
  double shift_bound() const { return shift_bound_; }
  double shift_limit() const { return shift_limit_; }
  // The total mass's cubature error in samples, N sum_b error_b, and its limit shift_tol sqrt(N).
  double mass_error() const { return mass_error_; }
  double mass_limit() const { return mass_limit_; }
  // Peaks the cubature could not resolve: bins where the pdf at a pilot point showed a peak the tree
  // wanted to split for but could not (max_depth or the evaluation budget), and whose integral after
  // refinement is still far below that peak times the bin's area (the peak test of the tree). Their
  // count, and the samples those peaks could hold, total * sum of peak x area (an upper bound on the
  // mass the cubature may have missed there, in samples). While it is large, the integrals and their
  // error estimates cannot be trusted (docs/math/sampling.md#unresolved-pdf).
  std::size_t unresolved_peaks() const { return unresolved().first; }
  double unresolved_reach() const { return unresolved().second; }

  // Bin index of each point given by its square coordinates (s < 0: lost, index -1).
  void locate(const double* s, const double* t, std::size_t count, std::int64_t* bin) const;
  // Adds the points' bins to `counts` (size()) and their lost ones to `lost`; multithreaded,
  // deterministic (integer counts).
  void count(Domain d, const double* points, std::size_t n, double unit_tol, std::vector<double>& counts,
             double& lost) const;

 private:
  struct Task {  // one cell whose cubature is pending
    Rect r;
    int depth;          // quadtree depth (tree phase) or sub-depth inside its bin (refine phase)
    std::int64_t node;  // tree node (tree phase) or bin index (refine phase)
  };
  struct Node {
    std::int64_t child = -1;  // first of 4 children (s low/high x t low/high), -1 for a leaf
    std::int64_t leaf = -1;   // bin index of a leaf
  };
  struct SubCell {
    Rect r;
    int depth;
    double value, err, top;  // integral, error, largest node value (density on the square)
  };

  void init_grid();
  void emit_nodes();
  void finish_tree_round(const std::vector<double>& value, const std::vector<double>& err,
                         const std::vector<double>& top);
  void start_refinement();
  void plan_refinement();
  // shift_bound_, shift_limit_ and, per bin, the derivative of the bound in the bin's error (in samples).
  void global_shift(std::vector<double>& weight);
  void finish_refine_round(const std::vector<double>& value, const std::vector<double>& err,
                           const std::vector<double>& top);
  std::int64_t descend(double s, double t) const;

  Domain domain_;
  BinOptions opt_;
  bool tree_phase_ = true;
  bool grid_ = false;
  std::vector<double> s_edges_, t_edges_;
  std::vector<Node> tree_;
  std::vector<Rect> tree_rect_;
  std::vector<double> tree_val_, tree_err_, tree_top_;
  std::vector<int> tree_depth_;
  std::vector<Task> pending_;
  std::vector<double> nodes_;
  // pilot points, reordered so that each pending tree cell's points are contiguous
  std::vector<double> ps_, pt_, pq_;
  std::vector<std::pair<std::size_t, std::size_t>> pilot_range_;  // per pending task
  double pilot_scale_ = 0.0, pilot_drawn_ = 0.0;
  std::vector<Rect> leaves_;
  std::vector<int> depth_;
  std::vector<double> integral_, error_;
  std::vector<std::vector<SubCell>> sub_;  // integration cells of each bin
  std::size_t evaluations_ = 0, unconverged_ = 0;
  double shift_bound_ = 0.0, shift_limit_ = 0.0, mass_error_ = 0.0, mass_limit_ = 0.0;
  std::size_t shift_met_at_ = 0;  // evaluations when the global rule's bound first met its limit
  int rounds_ = 0;
  // Tree cells that wanted a split for a peak at a pilot point and could not: (node, peak density) in the
  // tree phase, (bin, peak density) once the leaves are numbered.
  std::vector<std::pair<std::int64_t, double>> stuck_;
  // (count, samples) of the stuck bins whose peak the refinement has not resolved either.
  std::pair<std::size_t, double> unresolved() const;
};

// Genz-Malik's degree-7 rule with its embedded degree-5 rule on a rectangle of the square, 17 nodes:
// fills `st` with the 17 (s, t) nodes; `integrate` turns the 17 values into (integral, |I7 - I5|).
constexpr int kGenzMalikNodes = 17;
void genz_malik_nodes(const Rect& r, double* st);
void genz_malik_integrate(const Rect& r, const double* values, double& integral, double& error);

struct ChiSquare {
  double statistic = 0.0;
  int dof = 0;
  double pvalue = 1.0;                     // combined (chi-square and, where separate, the lost-sample test)
  double pvalue_chi2 = 1.0;                // chi-square alone
  double pvalue_lost = 1.0;                // lost samples alone (exact two-sided Poisson test)
  std::vector<std::size_t> starts;         // first bin of each merged bin (bins in order)
  std::vector<double> observed, expected;  // per merged bin
  double lost_expected = 0.0, lost_observed = 0.0;
  std::string note;
};

// Pearson chi-square of counts per bin against total * integral per bin, bins merged as chi2_test
// merges (merge_starts), and the lost bin: expected total * (1 - sum integral), tested by an exact
// two-sided Poisson test against the range of losses the cubature error allows (a mass above 1 beyond
// its error fails as a "too few lost" side: P = exp(total (1 - M + e))); the two p-values are combined
// by a weighted Bonferroni rule (95 % chi-square, 5 % lost samples) in `pvalue` (the Python harness
// recombines them with its rows' chi-square, docs/math/sampling.md#lost-sample-bin).
ChiSquare chi_square(const std::vector<double>& observed, const std::vector<double>& integral,
                     const std::vector<double>& error, double lost, double total, double min_expected);

}  // namespace glintlab::sampling
