#include "glintlab/counting/aniso.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numbers>
#include <stdexcept>

#include "base/parallel.hpp"
#include "base/splitmix.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/detail/aniso_stages.hpp"
#include "glintlab/detail/law_kernel.hpp"

namespace glintlab::aniso {

namespace stages = glintlab::detail::aniso_stages;

const char* status_name(ShapeStatus status) {
  switch (status) {
    case ShapeStatus::kOk: return "ok";
    case ShapeStatus::kDegenerate: return "degenerate";
    case ShapeStatus::kNonFinite: return "non_finite";
    case ShapeStatus::kClamped: return "clamped";
  }
  return "unknown";
}

namespace {
double wrap_angle(double angle) {
  double a = std::fmod(angle, std::numbers::pi);
  if (a < 0) a += std::numbers::pi;
  if (a >= std::numbers::pi) a = 0;  // fmod can round up to π
  return a;
}
}  // namespace

Shape shape_from_jacobian(double dudx, double dvdx, double dudy, double dvdy) {
  Shape s;
  if (!std::isfinite(dudx) || !std::isfinite(dvdx) || !std::isfinite(dudy) || !std::isfinite(dvdy)) {
    s.status = ShapeStatus::kNonFinite;
    return s;
  }
  // Singular values of J from J J^T; the minor one from |det J| / s1, which keeps the area exact
  // when the ellipse is thin (mean - diff cancels).
  const double p = dudx * dudx + dudy * dudy, q = dudx * dvdx + dudy * dvdy, r = dvdx * dvdx + dvdy * dvdy;
  const double mean = 0.5 * (p + r), diff = std::hypot(0.5 * (p - r), q);
  const double s1 = std::sqrt(mean + diff);
  const double det = std::abs(dudx * dvdy - dudy * dvdx);
  if (!(s1 > 0) || !(det > 0) || !std::isfinite(s1) || !std::isfinite(det)) {
    s.status = ShapeStatus::kDegenerate;
    return s;
  }
  const double s2 = det / s1;
  if (!(s2 > 0) || s1 / s2 > kMaxRatio) {
    s.status = ShapeStatus::kDegenerate;
    return s;
  }
  const double k = 1.0 / std::sqrt(std::numbers::pi);
  s.major = k * s1;
  s.minor = k * s2;
  s.area = det;
  s.ratio = std::max(1.0, s1 / s2);
  s.angle = wrap_angle(0.5 * std::atan2(2 * q, p - r));
  return s;
}

Shape shape_from_params(double area, double ratio, double angle) {
  const char* where = "footprint shape";
  if (!(area > 0) || !std::isfinite(area)) throw_invalid(where, "P", area, "a finite footprint area > 0");
  if (!(ratio >= 1) || !(ratio <= kMaxRatio)) throw_invalid(where, "r", ratio, "an anisotropy ratio in [1, 1e12]");
  if (!std::isfinite(angle)) throw_invalid(where, "phi", angle, "a finite angle (radians)");
  Shape s;
  s.area = area;
  s.ratio = ratio;
  s.major = std::sqrt(area * ratio / std::numbers::pi);
  s.minor = std::sqrt(area / (ratio * std::numbers::pi));
  s.angle = wrap_angle(angle);
  return s;
}

// ---------------------------------------------------------------------------------------------
// Registry

Registry<GridSchemeInfo>& grid_scheme_registry() {
  static Registry<GridSchemeInfo> schemes("grid scheme");
  return schemes;
}

bool register_grid_scheme(GridSchemeInfo info) { return grid_scheme_registry().add(std::move(info)); }

std::vector<GridSchemeInfo> registered_grid_schemes() { return grid_scheme_registry().all(); }

std::unique_ptr<GridScheme> make_grid_scheme(const std::string& name, const LawParams& params) {
  return grid_scheme_registry().make(name, params);
}

namespace {
const std::vector<std::pair<std::string, Spatial>> kSpatial = {
    {"none", Spatial::kNone}, {"square", Spatial::kSquare}, {"simplex", Spatial::kSimplex}};
const std::vector<std::pair<std::string, Angular>> kAngular = {{"none", Angular::kNone},
                                                               {"bilinear", Angular::kBilinear}};
const std::vector<std::pair<std::string, Realization>> kRealization = {{"blend", Realization::kBlend},
                                                                       {"select", Realization::kSelect}};
}  // namespace

Spatial spatial_from_name(const std::string& name) { return parse_enum("", "spatial", name, kSpatial); }
Angular angular_from_name(const std::string& name) { return parse_enum("", "angular", name, kAngular); }
Realization realization_from_name(const std::string& name) { return parse_enum("", "realization", name, kRealization); }
std::string spatial_name(Spatial s) { return enum_name(s, kSpatial); }
std::string angular_name(Angular a) { return enum_name(a, kAngular); }
std::string realization_name(Realization r) { return enum_name(r, kRealization); }

// ---------------------------------------------------------------------------------------------
// Interpolation weights

namespace weights {

std::array<double, 4> barycentric(const std::array<double, 3>& q, const std::array<std::array<double, 3>, 4>& t) {
  // Solve [t0 - t3, t1 - t3, t2 - t3] λ = q - t3 by Cramer's rule.
  double m[3][3], b[3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)
      m[i][j] = t[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)] - t[3][static_cast<std::size_t>(i)];
    b[i] = q[static_cast<std::size_t>(i)] - t[3][static_cast<std::size_t>(i)];
  }
  auto det3 = [](const double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const double d = det3(m);
  std::array<double, 4> w{};
  for (int c = 0; c < 3; ++c) {
    double mc[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) mc[i][j] = j == c ? b[i] : m[i][j];
    w[static_cast<std::size_t>(c)] = det3(mc) / d;
  }
  w[3] = 1.0 - w[0] - w[1] - w[2];
  return w;
}

// Inlined into the counter's per-term loop (a call per term and lattice cost more than the work).
inline int spatial_vertices_inline(Spatial spatial, double X, double Y, Vertex2* out) {
  const double fx0 = std::floor(X), fy0 = std::floor(Y);
  const auto i = static_cast<std::int64_t>(fx0), j = static_cast<std::int64_t>(fy0);
  switch (spatial) {
    case Spatial::kNone: out[0] = {i, j, 1.0}; return 1;
    case Spatial::kSquare: {
      const double fx = X - fx0, fy = Y - fy0;
      out[0] = {i, j, (1 - fx) * (1 - fy)};
      out[1] = {i + 1, j, fx * (1 - fy)};
      out[2] = {i, j + 1, (1 - fx) * fy};
      out[3] = {i + 1, j + 1, fx * fy};
      return 4;
    }
    case Spatial::kSimplex: {
      // Skew the square lattice onto a lattice of equilateral triangles of unit side: lattice point
      // (s, t) sits at (s + t/2, t sqrt(3)/2). Each skewed unit square holds two triangles.
      const double t = Y * (2.0 / std::sqrt(3.0));
      const double s = X - 0.5 * t;
      const double fs0 = std::floor(s), ft0 = std::floor(t);
      const auto si = static_cast<std::int64_t>(fs0), ti = static_cast<std::int64_t>(ft0);
      const double fs = s - fs0, ft = t - ft0;
      if (fs + ft < 1) {
        out[0] = {si, ti, 1 - fs - ft};
        out[1] = {si + 1, ti, fs};
        out[2] = {si, ti + 1, ft};
      } else {
        out[0] = {si + 1, ti + 1, fs + ft - 1};
        out[1] = {si, ti + 1, 1 - fs};
        out[2] = {si + 1, ti, 1 - ft};
      }
      return 3;
    }
  }
  return 0;
}

int spatial_vertices(Spatial spatial, double X, double Y, Vertex2* out) {
  return spatial_vertices_inline(spatial, X, Y, out);
}

}  // namespace weights

// ---------------------------------------------------------------------------------------------
// The counter

namespace {
using glintlab::detail::mix64;
std::uint64_t hash_combine(std::uint64_t h, std::uint64_t v) { return mix64(h ^ mix64(v)); }
// The key of one grid (scale, ratio, orientation level) under a seed, then of one of its angular
// texels.
std::uint64_t grid_key(std::uint64_t seed, const GridId& g) {
  std::uint64_t h = hash_combine(seed, static_cast<std::uint64_t>(static_cast<std::int64_t>(g.scale)));
  h = hash_combine(h, static_cast<std::uint64_t>(g.ratio));
  return hash_combine(h, static_cast<std::uint64_t>(g.orientation));
}
std::uint64_t texel_key(std::uint64_t grid, std::int64_t ax, std::int64_t ay) {
  return mix64(grid + static_cast<std::uint64_t>(ax) * 0xE7037ED1A0B428DBULL +
               static_cast<std::uint64_t>(ay) * 0x8EBC6AF09C88C6E3ULL);
}
// Cell (cx, cy) of a keyed grid: its uniforms, a pure function of (key, cx, cy, d). A shader reads
// these from a hash or a noise texture; splitmix64 outputs (which pass BigCrush as a counter-based
// generator) cost a few ns each, where a Philox block per cell would dominate an image's cost.
struct CellUniforms {
  std::uint64_t h;
  CellUniforms(std::uint64_t key, std::int64_t cx, std::int64_t cy) : h(mix64(cell_input(key, cx, cy))) {}
  static std::uint64_t cell_input(std::uint64_t key, std::int64_t cx, std::int64_t cy) {
    return key + static_cast<std::uint64_t>(cx) * 0xD1B54A32D192ED03ULL +
           static_cast<std::uint64_t>(cy) * 0xABC98388FB8FAC03ULL;
  }
  static double unit(std::uint64_t x) {
    return (static_cast<double>(x >> 11) + 0.5) * 0x1.0p-53;
  }  // open (0, 1), as CounterRng
  double operator()(std::size_t d) const { return unit(d == 0 ? h : mix64(h + d * 0x8CB92BA72F3D8DD7ULL)); }
};
// The uniforms of gathered cells: rows[r] holds CellUniforms::cell_input of row r, u gets row r's nu
// uniforms at u[r * nu]. A pass of its own (not in the per-term code): the rows are independent, so
// the hash chains overlap instead of waiting on each term's geometry. Integer hashing and exact
// conversions only (x >> 11 < 2^53), so the vector clones give the same bits as the scalar one.
__attribute__((target_clones("arch=x86-64-v4", "avx2", "default"))) void cell_uniform_rows(const std::uint64_t* rows,
                                                                                           std::size_t count,
                                                                                           std::size_t nu, double* u) {
  if (nu == 2) {  // the gated and binomial-family laws
    for (std::size_t r = 0; r < count; ++r) {
      const std::uint64_t h = mix64(rows[r]);
      u[2 * r] = CellUniforms::unit(h);
      u[2 * r + 1] = CellUniforms::unit(mix64(h + 0x8CB92BA72F3D8DD7ULL));
    }
    return;
  }
  for (std::size_t r = 0; r < count; ++r) {
    const std::uint64_t h = mix64(rows[r]);
    for (std::size_t d = 0; d < nu; ++d)
      u[r * nu + d] = CellUniforms::unit(d == 0 ? h : mix64(h + d * 0x8CB92BA72F3D8DD7ULL));
  }
}
constexpr std::size_t kChunk = 256;
// Beyond this many rows a thread gives its buffers back after the chunk (a wide scheme's one-off).
constexpr std::size_t kKeptRows = std::size_t{1} << 16;
// The rows a chunk gathers: per thread, kept between chunks and calls, so a chunk neither zero-fills
// nor page-faults fresh buffers. A call made from inside the inner law (a Python law counting an
// image) finds the thread's buffers in use and gets its own.
class CellRowsLease {
 public:
  CellRowsLease() {
    thread_local stages::CellRows rows;
    held_ = &rows;
    if (held_->in_use) {
      own_ = std::make_unique<stages::CellRows>();
      held_ = own_.get();
    }
    held_->in_use = true;
  }
  ~CellRowsLease() {
    held_->in_use = false;
    if (held_->n.size() > kKeptRows) *held_ = stages::CellRows{};
  }
  CellRowsLease(const CellRowsLease&) = delete;
  CellRowsLease& operator=(const CellRowsLease&) = delete;
  stages::CellRows& operator*() { return *held_; }

 private:
  stages::CellRows* held_;
  std::unique_ptr<stages::CellRows> own_;
};
}  // namespace

AnisoCounter::AnisoCounter(std::shared_ptr<const GridScheme> scheme, InnerLaw inner, CounterOptions options)
    : scheme_(std::move(scheme)), inner_(std::move(inner)), options_(options) {
  if (!scheme_) throw_invalid_message("scheme: missing");
  if (inner_.n_uniforms < 0 || inner_.n_uniforms > 16)
    throw_invalid_message("inner law: n_uniforms = " + std::to_string(inner_.n_uniforms) + ", expected 0 to 16");
}

int AnisoCounter::evaluations_per_term() const {
  if (options_.realization == Realization::kSelect) return 1;
  const int spatial = options_.spatial == Spatial::kNone ? 1 : options_.spatial == Spatial::kSquare ? 4 : 3;
  const int angular = options_.angular == Angular::kNone ? 1 : 4;
  return spatial * angular;
}

bool AnisoCounter::integer_output() const {
  return inner_.integer_output && scheme_->independent_terms() && evaluations_per_term() == 1;
}

bool AnisoCounter::has_pmf() const { return integer_output() && inner_.law && inner_.law->has_pmf(); }

std::vector<Term> AnisoCounter::terms(double density, const Shape& shape, bool* clamped) const {
  const std::string where = "aniso_counter('" + scheme_->name() + "')";
  check_n(where, density, "N");
  if (shape.status == ShapeStatus::kDegenerate || shape.status == ShapeStatus::kNonFinite)
    throw_invalid_message(where + ": the footprint is " + status_name(shape.status));
  std::vector<Term> out;
  const bool c = scheme_->terms(shape, density, out);
  if (clamped) *clamped = c;
  return out;
}

// ---------------------------------------------------------------------------------------------
// The counter's stages (glintlab/detail/aniso_stages.hpp)

}  // namespace glintlab::aniso

namespace glintlab::detail::aniso_stages {

using aniso::CellUniforms;

void CellRows::grow(std::size_t rows, std::size_t nu) {
  rows = std::max(rows, 2 * n.size());
  n.resize(rows), p.resize(rows), coef.resize(rows), k.resize(rows), owner.resize(rows), cell.resize(rows);
  term.resize(rows);
  if (u.size() < n.size() * nu) u.resize(n.size() * nu);
}

std::uint64_t image_select_seed(std::uint64_t seed) { return aniso::hash_combine(seed, 0x5E1EC7ULL); }

void cell_uniforms(std::uint64_t cell, std::size_t nu, double* u) { aniso::cell_uniform_rows(&cell, 1, nu, u); }

TermCells::TermCells(const CounterOptions& options, std::size_t max_terms)
    : spatial_(options.spatial),
      angular_lattice_(options.angular == aniso::Angular::kNone ? Spatial::kNone : Spatial::kSquare),
      select_(options.realization == aniso::Realization::kSelect), grids_(max_terms) {}

__attribute__((always_inline)) inline std::size_t TermCells::gather_inline(const Pixel& px, std::size_t i,
                                                                           std::size_t ti, const Term& t, CellRows& g,
                                                                           std::size_t at) {
  const double x = px.u + t.dx, y = px.v + t.dy;
  // The term angle's cosine and sine, memoized (direct mapped on the angle's bits): the schemes use a few grid
  // orientations, so nearly every term reuses a value std::cos / std::sin already gave for the same argument.
  std::uint64_t angle_bits;
  std::memcpy(&angle_bits, &t.angle, sizeof angle_bits);
  TrigMemo& memo = trig_[(angle_bits ^ (angle_bits >> 29) ^ (angle_bits >> 47)) & (trig_.size() - 1)];
  if (memo.bits != angle_bits) memo = {angle_bits, std::cos(t.angle), std::sin(t.angle)};
  const double c = memo.c, s = memo.s;
  // Grid coordinates: across the long side (X) and along it (Y), in cells.
  const double X = (-x * s + y * c) / t.cell_minor, Y = (x * c + y * s) / t.cell_major;
  aniso::weights::Vertex2 sv[4], av[4];
  int ns = aniso::weights::spatial_vertices_inline(spatial_, X, Y, sv);
  int na = aniso::weights::spatial_vertices_inline(angular_lattice_, px.su, px.sv, av);
  if (select_ && (ns > 1 || na > 1)) {
    // One vertex with probability v_j (inversion of the running sum), for each lattice. (A single vertex is its
    // own pick: its uniforms would go unread, so they are not drawn.)
    const CellUniforms pick_u(px.select_seed, static_cast<std::int64_t>(i), static_cast<std::int64_t>(ti));
    auto pick = [](aniso::weights::Vertex2* v, int count, double r) {
      double acc = 0;
      int q = 0;
      for (; q < count - 1; ++q) {
        acc += v[q].w;
        if (r < acc) break;
      }
      v[0] = {v[q].i, v[q].j, 1.0};
    };
    pick(sv, ns, pick_u(0));
    pick(av, na, pick_u(1));
    ns = na = 1;
  }
  // The grid's key under the pixel's grid seed, memoized per term slot, then each angular texel's.
  if (ti >= grids_.size()) grids_.resize(ti + 1);
  GridMemo& gm = grids_[ti];
  if (!gm.set || gm.seed != px.grid_seed || gm.grid.scale != t.grid.scale || gm.grid.ratio != t.grid.ratio ||
      gm.grid.orientation != t.grid.orientation) {
    const std::uint64_t key = aniso::grid_key(px.grid_seed, t.grid);
    gm = {t.grid, px.grid_seed, key, true, av[0].i, av[0].j, aniso::texel_key(key, av[0].i, av[0].j)};
  }
  std::size_t rows = 0;
  for (int b = 0; b < na; ++b) {
    if (av[b].i != gm.texel_i || av[b].j != gm.texel_j)
      gm.texel_i = av[b].i, gm.texel_j = av[b].j, gm.texel = aniso::texel_key(gm.key, av[b].i, av[b].j);
    for (int a = 0; a < ns; ++a, ++rows) {
      g.cell[at + rows] = CellUniforms::cell_input(gm.texel, sv[a].i, sv[a].j);
      g.coef[at + rows] = t.scale * sv[a].w * av[b].w;
    }
  }
  for (std::size_t q = at; q < at + rows; ++q) {
    g.n[q] = t.trials;
    g.p[q] = px.p;
    g.owner[q] = i;
    g.term[q] = static_cast<std::uint32_t>(ti);
  }
  return rows;
}

std::size_t TermCells::gather(const Pixel& px, std::size_t i, std::size_t ti, const Term& t, CellRows& rows,
                              std::size_t at) {
  return gather_inline(px, i, ti, t, rows, at);
}

namespace {
// The rows grouped by term (a stable counting sort on the term index): each term's rows go to its fixed evaluator
// at once (a table lookup per row where the law tabulates, where the per-pixel path would rebuild the law's
// constants for every row), the rest to the per-pixel path.
void evaluate_by_term(const InnerLaw& inner, const std::vector<std::shared_ptr<const FixedEvaluator>>& fixed,
                      CellRows& g, std::size_t rows, std::size_t nu) {
  thread_local std::vector<std::size_t> start, order;
  thread_local std::vector<double> u_sorted, k_sorted, n_rest, p_rest;
  const std::size_t nt = fixed.size();
  start.assign(nt + 1, 0);
  for (std::size_t q = 0; q < rows; ++q) ++start[g.term[q] + 1];
  for (std::size_t t = 0; t < nt; ++t) start[t + 1] += start[t];
  order.resize(rows);
  {
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    for (std::size_t q = 0; q < rows; ++q) order[next[g.term[q]]++] = q;
  }
  u_sorted.resize(rows * nu);
  k_sorted.resize(rows);
  for (std::size_t s = 0; s < rows; ++s)
    std::memcpy(u_sorted.data() + s * nu, g.u.data() + order[s] * nu, nu * sizeof(double));
  for (std::size_t t = 0; t < nt; ++t) {
    const std::size_t a = start[t], b = start[t + 1];
    if (a == b) continue;
    if (fixed[t]) {
      fixed[t]->evaluate(u_sorted.data() + a * nu, b - a, k_sorted.data() + a);
    } else {
      n_rest.resize(b - a), p_rest.resize(b - a);
      for (std::size_t s = a; s < b; ++s) n_rest[s - a] = g.n[order[s]], p_rest[s - a] = g.p[order[s]];
      inner.evaluate(n_rest.data(), p_rest.data(), u_sorted.data() + a * nu, b - a, k_sorted.data() + a);
    }
  }
  for (std::size_t s = 0; s < rows; ++s) g.k[order[s]] = k_sorted[s];
}
}  // namespace

void evaluate_cells(const InnerLaw& inner, const std::vector<std::shared_ptr<const FixedEvaluator>>* fixed,
                    CellRows& rows, std::size_t count) {
  const auto nu = static_cast<std::size_t>(inner.n_uniforms);
  aniso::cell_uniform_rows(rows.cell.data(), count, nu, rows.u.data());
  if (fixed)
    evaluate_by_term(inner, *fixed, rows, count, nu);
  else
    inner.evaluate(rows.n.data(), rows.p.data(), rows.u.data(), count, rows.k.data());
}

void accumulate_cells(const CellRows& rows, std::size_t count, double* k_out, const std::string& where) {
  const double *k = rows.k.data(), *coef = rows.coef.data();
  const std::size_t* owner = rows.owner.data();
  for (std::size_t q = 0; q < count; ++q) {
    if (!std::isfinite(k[q]))
      throw_invalid_message(where + ": the inner law returned " + format_value(k[q]) +
                            " at n = " + format_value(rows.n[q]) + ", p = " + format_value(rows.p[q]));
    if (coef[q] != 0.0) k_out[owner[q]] += coef[q] * k[q];
  }
}

}  // namespace glintlab::detail::aniso_stages

namespace glintlab::aniso {

template <class Source>
void AnisoCounter::run(double density, std::size_t m, Source source, double* k_out, std::int32_t* evals_out,
                       std::uint8_t* status_out, SharedFootprint shared) const {
  const std::string where = "aniso_counter('" + scheme_->name() + "', inner='" + inner_.name + "')";
  const std::size_t nu = static_cast<std::size_t>(inner_.n_uniforms);
  // Rows a chunk can gather at most: every buffer is sized once per chunk, so the gather never reallocates (no
  // regrowth copies) and writes by index.
  const std::size_t rows_per_term = static_cast<std::size_t>(evaluations_per_term());
  const std::size_t max_terms = scheme_->max_terms();
  auto chunk_body = [&](std::size_t i0, std::size_t i1) {
    CellRowsLease lease;
    stages::CellRows& rows = *lease;
    rows.ensure_rows((i1 - i0) * std::min<std::size_t>(max_terms, 8) * rows_per_term, nu);
    stages::TermCells cells(options_, max_terms);
    std::vector<Term> terms;
    terms.reserve(max_terms);
    std::size_t gathered = 0;
    for (std::size_t i = i0; i < i1; ++i) {
      stages::Pixel px;
      Shape shape;
      source(i, px, shape);
      k_out[i] = 0.0;
      if (evals_out) evals_out[i] = 0;
      ShapeStatus status;
      if (!stages::footprint_terms(*scheme_, density, shape, shared.terms, terms, status)) {
        if (status_out) status_out[i] = static_cast<std::uint8_t>(status);
        continue;
      }
      if (shared.fixed && terms.size() != shared.fixed->size())
        throw_invalid_message(where + ": internal: the footprint's terms changed between pixels");
      if (status_out) status_out[i] = static_cast<std::uint8_t>(status);
      rows.ensure_rows(gathered + terms.size() * rows_per_term, nu);
      std::int32_t evaluations = 0;
      for (std::size_t ti = 0; ti < terms.size(); ++ti) {
        const Term& t = terms[ti];
        if (inner_.law && t.trials > 0 && !inner_.law->accepts(t.trials, px.p))
          throw_invalid_message(where + ": the inner law refuses its trial count n = " + format_value(t.trials) +
                                " at p = " + format_value(px.p));
        const std::size_t added = cells.gather_inline(px, i, ti, t, rows, gathered);
        evaluations += static_cast<std::int32_t>(added);
        gathered += added;
      }
      if (evals_out) evals_out[i] = evaluations;
    }
    if (gathered == 0) return;
    // Every evaluation of the chunk is gathered and made at once (vector code for the laws that have it), then
    // summed per pixel in term order: the same operations in the same order as summing each term as it comes.
    stages::evaluate_cells(inner_, shared.fixed, rows, gathered);
    stages::accumulate_cells(rows, gathered, k_out, where);
  };
  if (inner_.thread_safe) {
    detail::parallel_chunks(m, kChunk, kChunk, chunk_body);
  } else {
    for (std::size_t i0 = 0; i0 < m; i0 += kChunk) chunk_body(i0, std::min(m, i0 + kChunk));
  }
}

namespace {
void check_trials(const std::string& where, const InnerLaw& inner, const std::vector<Term>& terms, double p) {
  if (!inner.law) return;
  for (const Term& t : terms)
    if (t.trials > 0 && !inner.law->accepts(t.trials, p))
      throw_invalid_message(where + ": the inner law refuses its trial count n = " + format_value(t.trials) +
                            " at p = " + format_value(p));
}
}  // namespace

void AnisoCounter::count_pixels(double density, ParamArray p, const double* uv, const double* jac, const double* slope,
                                std::size_t m, std::uint64_t seed, PixelOutput out) const {
  const std::string where = "aniso_counter('" + scheme_->name() + "').count_image";
  check_n(where, density, "N");
  check_length(where, "p", p.size, m);
  for (std::size_t i = 0; i < p.size; ++i) check_p(where, p[i], indexed_name("p", i, p.size > 1));
  for (std::size_t i = 0; i < 2 * m; ++i) {
    if (!std::isfinite(uv[i]) || std::abs(uv[i]) > 1e9)
      throw_invalid(where, indexed_name("uv", i, true), uv[i], "a finite texture coordinate, |uv| <= 1e9");
    if (slope && (!std::isfinite(slope[i]) || std::abs(slope[i]) > 1e9))
      throw_invalid(where, indexed_name("slope", i, true), slope[i], "a finite angular coordinate, |slope| <= 1e9");
  }
  const std::uint64_t select_seed = stages::image_select_seed(seed);
  run(
      density, m,
      [&](std::size_t i, stages::Pixel& px, Shape& shape) {
        shape = shape_from_jacobian(jac[4 * i], jac[4 * i + 1], jac[4 * i + 2], jac[4 * i + 3]);
        px = {uv[2 * i], uv[2 * i + 1], slope ? slope[2 * i] : 0.0, slope ? slope[2 * i + 1] : 0.0, p[i],
              seed,      select_seed};
      },
      out.count, out.evaluations, out.status);
}

void AnisoCounter::sample(double density, double p, const Shape& shape, std::size_t count, std::uint64_t seed,
                          double* out) const {
  const std::string where = "aniso_counter('" + scheme_->name() + "').sample";
  check_p(where, p);
  const std::vector<Term> ts = terms(density, shape);
  check_trials(where, inner_, ts, p);
  // Positions uniform over a square many cells wide in every grid, so each grid's phase is uniform
  // within 1e-6; fresh grids per realization make the absolute position irrelevant otherwise.
  double extent = 0;
  for (const Term& t : ts) extent = std::max({extent, t.cell_major, t.cell_minor});
  const double width = 1e6 * (extent > 0 ? extent : 1.0);
  // Every realization has the same terms: one evaluator per term at (trials, p), prepared once for
  // the rows it will get (count x the term's evaluations), where the inner law offers one.
  std::vector<std::shared_ptr<const detail::FixedEvaluator>> fixed;
  if (inner_.fixed_evaluator && inner_.thread_safe && count >= kTabulateMinBatch) {
    fixed.resize(ts.size());
    const std::size_t rows = count * static_cast<std::size_t>(evaluations_per_term());
    for (std::size_t ti = 0; ti < ts.size(); ++ti)
      if (ts[ti].trials > 0) fixed[ti] = inner_.fixed_evaluator(ts[ti].trials, p, rows);
  }
  run(
      density, count,
      [&](std::size_t r, stages::Pixel& px, Shape& s) {
        CounterRng rng(seed, static_cast<std::uint32_t>(r), static_cast<std::uint32_t>(r >> 32), 0,
                       kStreamAnisoPosition);
        const double u = rng.uniform() * width, v = rng.uniform() * width;
        const double su = rng.uniform() * 65536.0, sv = rng.uniform() * 65536.0;
        px = {u, v, su, sv, p, hash_combine(seed, r), hash_combine(seed ^ 0x5E1EC7ULL, r)};
        s = shape;
      },
      out, nullptr, nullptr, SharedFootprint{&ts, fixed.empty() ? nullptr : &fixed});
}

Distribution AnisoCounter::pmf(double density, double p, const Shape& shape, std::size_t max_support) const {
  const std::string where = "aniso_counter('" + scheme_->name() + "', inner='" + inner_.name + "').pmf";
  if (!has_pmf()) {
    std::string why = !inner_.law || !inner_.law->has_pmf() ? "the inner law has no exact distribution"
                      : !inner_.integer_output              ? "the inner law's counts are not integers"
                      : !scheme_->independent_terms()
                          ? "the scheme's terms share cells or are rescaled"
                          : "blended realizations are not integers (use realization='select')";
    throw not_implemented(where + ": no exact distribution: " + why);
  }
  check_p(where, p);
  const std::vector<Term> ts = terms(density, shape);
  check_trials(where, inner_, ts, p);
  Distribution total({0.0}, {1.0});
  for (const Term& t : ts) {
    if (!(t.trials > 0)) continue;
    const Distribution term = inner_.law->pmf(t.trials, p, max_support);
    // A law whose output is integer in its regime can leave it: "threshold" above its T returns the
    // mean n p, a point mass at a real number. A sum of such terms has no exact law on integer
    // counts; say so by name rather than let the convolution fail on a non-integer value.
    for (const double v : term.support())
      if (v != std::floor(v))
        throw not_implemented(where + ": no exact distribution: the inner law returns the non-integer value " +
                              format_value(v) + " at n = " + format_value(t.trials) + ", p = " + format_value(p) +
                              " (a count law's exact sum needs integer values; sample it instead)");
    total = convolve(total, term, max_support, where);
  }
  return total;
}

}  // namespace glintlab::aniso
