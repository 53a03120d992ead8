#include "glintlab/counting/spatial.hpp"
#include "glintlab/counting/aniso.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <map>
#include <mutex>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/binomial.hpp"

namespace glintlab::spatial {

namespace {

double cross(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

// Signed area of the unit disk ∩ triangle (O, P, Q): triangle pieces where the edge runs inside
// the disk, circular sectors where it runs outside.
double disk_triangle_area(double px, double py, double qx, double qy) {
  const double dx = qx - px, dy = qy - py;
  const double a = dx * dx + dy * dy;
  if (a == 0) return 0.0;
  const double b = 2 * (px * dx + py * dy), c = px * px + py * py - 1;
  double ts[4] = {0.0, 0.0, 0.0, 1.0};
  int nt = 1;
  const double disc = b * b - 4 * a * c;
  if (disc > 0) {
    const double r = std::sqrt(disc);
    // Numerically stable roots.
    const double q = -0.5 * (b + std::copysign(r, b));
    double t1 = q / a, t2 = q != 0 ? c / q : t1;
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > 0 && t1 < 1) ts[nt++] = t1;
    if (t2 > 0 && t2 < 1) ts[nt++] = t2;
  }
  ts[nt++] = 1.0;
  double area = 0;
  for (int i = 0; i + 1 < nt; ++i) {
    const double ax = px + ts[i] * dx, ay = py + ts[i] * dy;
    const double bx = px + ts[i + 1] * dx, by = py + ts[i + 1] * dy;
    const double tm = 0.5 * (ts[i] + ts[i + 1]);
    const double mx = px + tm * dx, my = py + tm * dy;
    if (mx * mx + my * my <= 1)
      area += 0.5 * cross(ax, ay, bx, by);
    else
      area += 0.5 * std::atan2(cross(ax, ay, bx, by), ax * bx + ay * by);
  }
  return area;
}

double polygon_area(const std::vector<std::pair<double, double>>& poly) {
  double area = 0;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const auto& [x0, y0] = poly[i];
    const auto& [x1, y1] = poly[(i + 1) % poly.size()];
    area += cross(x0, y0, x1, y1);
  }
  return 0.5 * area;
}

// Sutherland-Hodgman: keeps the part of `poly` where nx x + ny y <= d.
std::vector<std::pair<double, double>> clip(const std::vector<std::pair<double, double>>& poly, double nx, double ny,
                                            double d) {
  std::vector<std::pair<double, double>> out;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const auto [x0, y0] = poly[i];
    const auto [x1, y1] = poly[(i + 1) % poly.size()];
    const double f0 = nx * x0 + ny * y0 - d, f1 = nx * x1 + ny * y1 - d;
    if (f0 <= 0) out.emplace_back(x0, y0);
    if ((f0 < 0 && f1 > 0) || (f0 > 0 && f1 < 0)) {
      const double t = f0 / (f0 - f1);
      out.emplace_back(x0 + t * (x1 - x0), y0 + t * (y1 - y0));
    }
  }
  return out;
}

// Interval of x where lo_c <= x c + k <= hi_c (c may be 0: all x or none).
bool slab(double c, double k, double lo_c, double hi_c, double& lo, double& hi) {
  if (c == 0) {
    if (k < lo_c || k > hi_c) return false;
    return true;
  }
  double a = (lo_c - k) / c, b = (hi_c - k) / c;
  if (a > b) std::swap(a, b);
  lo = std::max(lo, a);
  hi = std::min(hi, b);
  return lo <= hi;
}

void check_length(std::string_view where, std::string_view name, double v) {
  if (!(v > 0) || !std::isfinite(v)) throw_invalid(where, name, v, "a finite length > 0");
}

}  // namespace

Layout parse_layout(const std::string& name) {
  static constexpr std::pair<std::string_view, Layout> kLayouts[] = {
      {"uniform", Layout::kUniform}, {"poisson", Layout::kPoisson}, {"stratified", Layout::kStratified}};
  return parse_enum("ground_truth", "layout", name, kLayouts);
}

std::string layout_name(Layout layout) {
  switch (layout) {
    case Layout::kUniform: return "uniform";
    case Layout::kPoisson: return "poisson";
    case Layout::kStratified: return "stratified";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// Footprint

Footprint::Footprint(Kind kind, double a, double b, double angle)
    : kind_(kind), a_(a), b_(b), angle_(angle), c_(std::cos(angle)), s_(std::sin(angle)) {
  if (kind_ == Kind::kRect) {
    half_w_ = 0.5 * (a_ * std::abs(c_) + b_ * std::abs(s_));
    half_h_ = 0.5 * (a_ * std::abs(s_) + b_ * std::abs(c_));
    // The leftmost (rightmost) point is a corner: the one with the smallest (largest) x.
    double best_l = 1e300, best_r = -1e300;
    for (int i = 0; i < 4; ++i) {
      const double u = (i & 1 ? 0.5 : -0.5) * a_, v = (i & 2 ? 0.5 : -0.5) * b_;
      const double x = u * c_ - v * s_, y = u * s_ + v * c_;
      if (x < best_l) best_l = x, y_left_ = y;
      if (x > best_r) best_r = x, y_right_ = y;
    }
  } else {
    half_w_ = std::sqrt(a_ * a_ * c_ * c_ + b_ * b_ * s_ * s_);
    half_h_ = std::sqrt(a_ * a_ * s_ * s_ + b_ * b_ * c_ * c_);
    // Extreme x of the ellipse at y = x_ext * (a^2 - b^2) s c / x_ext^2 (the tangent is vertical).
    const double y = (a_ * a_ - b_ * b_) * s_ * c_ / half_w_;
    y_left_ = -y;
    y_right_ = y;
  }
}

Footprint Footprint::rect(double width, double height, double angle) {
  check_length("Rect", "width", width);
  check_length("Rect", "height", height);
  if (!std::isfinite(angle)) throw_invalid("Rect", "angle", angle, "a finite angle in radians");
  return Footprint(Kind::kRect, width, height, angle);
}

Footprint Footprint::ellipse(double a, double b, double angle) {
  check_length("Ellipse", "a", a);
  check_length("Ellipse", "b", b);
  if (!std::isfinite(angle)) throw_invalid("Ellipse", "angle", angle, "a finite angle in radians");
  return Footprint(Kind::kEllipse, a, b, angle);
}

Footprint Footprint::from_uv_derivatives(double dudx, double dvdx, double dudy, double dvdy) {
  for (auto [name, v] : {std::pair{"dudx", dudx}, {"dvdx", dvdx}, {"dudy", dudy}, {"dvdy", dvdy}})
    if (!std::isfinite(v)) throw_invalid("Ellipse.from_uv_derivatives", name, v, "a finite number");
  const aniso::Shape s = aniso::shape_from_jacobian(dudx, dvdx, dudy, dvdy);
  if (s.status != aniso::ShapeStatus::kOk)
    throw_invalid("Ellipse.from_uv_derivatives", "det(J)", std::abs(dudx * dvdy - dudy * dvdx),
                  "a non-degenerate Jacobian (the derivatives span a parallelogram of area > 0, ratio <= 1e12)");
  return ellipse(s.major, s.minor, s.angle);
}

double Footprint::area() const { return kind_ == Kind::kRect ? a_ * b_ : std::numbers::pi * a_ * b_; }

bool Footprint::contains(double x, double y) const {
  const double u = x * c_ + y * s_, v = -x * s_ + y * c_;
  if (kind_ == Kind::kRect) return std::abs(u) <= 0.5 * a_ && std::abs(v) <= 0.5 * b_;
  return (u / a_) * (u / a_) + (v / b_) * (v / b_) <= 1.0;
}

bool Footprint::chord(double y, double& lo, double& hi) const {
  if (kind_ == Kind::kRect) {
    lo = -1e300;
    hi = 1e300;
    // |x c + y s| <= a/2 and |-x s + y c| <= b/2.
    if (!slab(c_, y * s_, -0.5 * a_, 0.5 * a_, lo, hi)) return false;
    if (!slab(-s_, y * c_, -0.5 * b_, 0.5 * b_, lo, hi)) return false;
    return lo <= hi && lo > -1e299;
  }
  // A x^2 + B x + C <= 0 with the rotated quadratic form.
  const double ia = 1 / (a_ * a_), ib = 1 / (b_ * b_);
  const double A = c_ * c_ * ia + s_ * s_ * ib;
  const double B = 2 * y * c_ * s_ * (ia - ib);
  const double C = y * y * (s_ * s_ * ia + c_ * c_ * ib) - 1;
  const double disc = B * B - 4 * A * C;
  if (disc < 0) return false;
  const double r = std::sqrt(disc);
  lo = (-B - r) / (2 * A);
  hi = (-B + r) / (2 * A);
  return true;
}

double Footprint::overlap(double x0, double y0, double x1, double y1) const {
  if (kind_ == Kind::kRect) {
    std::vector<std::pair<double, double>> poly{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
    // Half-planes |u| <= a/2, |v| <= b/2 with u = x c + y s, v = -x s + y c.
    poly = clip(poly, c_, s_, 0.5 * a_);
    if (!poly.empty()) poly = clip(poly, -c_, -s_, 0.5 * a_);
    if (!poly.empty()) poly = clip(poly, -s_, c_, 0.5 * b_);
    if (!poly.empty()) poly = clip(poly, s_, -c_, 0.5 * b_);
    return poly.size() < 3 ? 0.0 : std::abs(polygon_area(poly));
  }
  // Map the box into the frame where the ellipse is the unit disk; areas scale by a b.
  const double xs[4] = {x0, x1, x1, x0}, ys[4] = {y0, y0, y1, y1};
  double px[4], py[4];
  for (int i = 0; i < 4; ++i) {
    px[i] = (xs[i] * c_ + ys[i] * s_) / a_;
    py[i] = (-xs[i] * s_ + ys[i] * c_) / b_;
  }
  double area = 0;
  for (int i = 0; i < 4; ++i) area += disk_triangle_area(px[i], py[i], px[(i + 1) % 4], py[(i + 1) % 4]);
  return std::abs(area) * a_ * b_;
}

std::string Footprint::describe() const {
  std::ostringstream out;
  out.precision(6);
  if (kind_ == Kind::kRect)
    out << "Rect(width=" << a_ << ", height=" << b_ << ", angle=" << angle_ << ")";
  else
    out << "Ellipse(a=" << a_ << ", b=" << b_ << ", angle=" << angle_ << ")";
  return out.str();
}

// ---------------------------------------------------------------------------------------------
// Row scan: which cells of the grid of side h each footprint contains fully or crosses.

namespace {

struct RowSpan {  // cells [first, last] of a row (unwrapped indices), empty when first > last
  std::int64_t first = 1, last = 0;
};

struct Chord {
  bool hit = false;
  double lo = 0, hi = 0;
};

Chord chord_at(const Footprint& f, double y) {
  Chord c;
  c.hit = f.chord(y, c.lo, c.hi);
  return c;
}

// For the row strip [y0, y1] (relative to the footprint's centre) and cell side h with cell i
// covering [i h - cx, (i + 1) h - cx]: the cells fully inside and the cells touched. c0 and c1 are
// the chords at y0 and y1 (a scan passes each row edge's chord to both rows it bounds).
void row_spans(const Footprint& f, double cx, double y0, double y1, const Chord& c0, const Chord& c1, double h,
               RowSpan& inside, RowSpan& touched) {
  inside = RowSpan{};
  touched = RowSpan{};
  const double top = f.half_height();
  const double a = std::max(y0, -top), b = std::min(y1, top);
  if (a > b) return;
  // Touched: the chord's extreme ends over the strip (convex shape: at the strip's ends or at the
  // leftmost / rightmost point when it lies inside the strip).
  double lo_min = 1e300, hi_max = -1e300;
  const auto take = [&](const Chord& c) {
    if (c.hit) lo_min = std::min(lo_min, c.lo), hi_max = std::max(hi_max, c.hi);
  };
  take(a == y0 ? c0 : chord_at(f, a));
  take(b == y1 ? c1 : chord_at(f, b));
  if (f.y_leftmost() > a && f.y_leftmost() < b) take(chord_at(f, f.y_leftmost()));
  if (f.y_rightmost() > a && f.y_rightmost() < b) take(chord_at(f, f.y_rightmost()));
  if (lo_min > hi_max) return;
  touched.first = static_cast<std::int64_t>(std::floor((cx + lo_min) / h));
  touched.last = static_cast<std::int64_t>(std::floor((cx + hi_max) / h));
  // Inside: only if the whole strip lies within the footprint's height; the chord's left end is
  // convex in y, so its maximum over the strip is at an end (and the right end's minimum too).
  if (y0 < -top || y1 > top || !c0.hit || !c1.hit) return;
  const double lo_in = std::max(c0.lo, c1.lo), hi_in = std::min(c0.hi, c1.hi);
  if (lo_in >= hi_in) return;
  inside.first = static_cast<std::int64_t>(std::ceil((cx + lo_in) / h));
  inside.last = static_cast<std::int64_t>(std::floor((cx + hi_in) / h)) - 1;
}

std::int64_t scan_grid_side(Layout layout, double density) {
  const double side =
      layout == Layout::kStratified ? std::round(std::sqrt(density)) : std::max(1.0, std::floor(std::sqrt(density)));
  return static_cast<std::int64_t>(side);
}

void check_density(Layout layout, double density) {
  if (!(density >= 0) || !std::isfinite(density) || density > 1e18)
    throw_invalid("ground_truth", "density", density, "a finite number in [0, 1e18]");
  if (layout == Layout::kUniform && (density != std::floor(density) || density > 9007199254740992.0))
    throw_invalid("ground_truth", "density", density, "an integer number of facets (uniform layout)");
  if (layout == Layout::kStratified) {
    const double m = std::round(std::sqrt(density));
    if (m * m != density || m < 1) {
      const double lo = std::floor(std::sqrt(density)), hi = lo + 1;
      throw_invalid("ground_truth", "density", density,
                    "a perfect square M^2 >= 1 for the stratified layout (one facet per cell of an M x M grid), "
                    "e.g. " +
                        format_value(std::max(1.0, lo * lo)) + " or " + format_value(hi * hi));
    }
  }
}

// One realization of the layout counted in every footprint (centres already unwrapped so that
// all footprints sit together); out[j] = K_j.
class Scanner {
 public:
  Scanner(Layout layout, double density, double p, const std::vector<Placed>& fps)
      : layout_(layout), density_(density), p_(p), fps_(fps) {
    side_ = scan_grid_side(layout, density);
    h_ = 1.0 / static_cast<double>(side_);
    double ylo = 1e300, yhi = -1e300, xlo = 1e300, xhi = -1e300;
    for (const auto& f : fps_) {
      ylo = std::min(ylo, f.y - f.footprint.half_height());
      yhi = std::max(yhi, f.y + f.footprint.half_height());
      xlo = std::min(xlo, f.x - f.footprint.half_width());
      xhi = std::max(xhi, f.x + f.footprint.half_width());
    }
    if (xhi - xlo >= 1 || yhi - ylo >= 1)
      throw_invalid("ground_truth", "footprint extent", std::max(xhi - xlo, yhi - ylo),
                    "footprints that fit in the unit domain together (bounding box side < 1), so no "
                    "facet is counted twice on the torus");
    row_first_ = static_cast<std::int64_t>(std::floor(ylo / h_));
    row_last_ = static_cast<std::int64_t>(std::floor(yhi / h_));
  }

  // Adds K_j of realization `rng` to out[j] (out zeroed by the caller).
  void realize(CounterRng& rng, double* out) const {
    const std::size_t m = fps_.size();
    // Pass 1, geometry only: the cells an edge crosses, and runs of cells every footprint either
    // fully contains or misses, grouped by which footprints contain them (their signature).
    const std::size_t words = (m + 63) / 64;
    std::map<std::vector<std::uint64_t>, double> groups;            // signature -> number of cells
    std::vector<std::pair<std::int64_t, std::int64_t>> edge_cells;  // (column, row)
    std::vector<RowSpan> inside(m), touched(m);
    std::vector<Chord> below(m), above(m);  // chords at the current row's lower and upper edges
    for (std::size_t j = 0; j < m; ++j)
      below[j] = chord_at(fps_[j].footprint, static_cast<double>(row_first_) * h_ - fps_[j].y);
    std::vector<std::int64_t> cuts;
    std::vector<std::uint64_t> sig(words);
    for (std::int64_t row = row_first_; row <= row_last_; ++row) {
      const double y0 = static_cast<double>(row) * h_, y1 = y0 + h_;
      cuts.clear();
      for (std::size_t j = 0; j < m; ++j) {
        above[j] = chord_at(fps_[j].footprint, y1 - fps_[j].y);
        row_spans(fps_[j].footprint, fps_[j].x, y0 - fps_[j].y, y1 - fps_[j].y, below[j], above[j], h_, inside[j],
                  touched[j]);
        below[j] = above[j];
        if (touched[j].first > touched[j].last) continue;
        cuts.push_back(touched[j].first);
        cuts.push_back(touched[j].last + 1);
        if (inside[j].first <= inside[j].last) {
          cuts.push_back(inside[j].first);
          cuts.push_back(inside[j].last + 1);
        }
      }
      if (cuts.empty()) continue;
      std::sort(cuts.begin(), cuts.end());
      cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
      for (std::size_t s = 0; s + 1 < cuts.size(); ++s) {
        const std::int64_t c0 = cuts[s], c1 = cuts[s + 1];  // cells [c0, c1)
        bool edge = false, any = false;
        std::fill(sig.begin(), sig.end(), 0);
        for (std::size_t j = 0; j < m; ++j) {
          if (c0 < touched[j].first || c0 > touched[j].last) continue;
          if (c0 >= inside[j].first && c0 <= inside[j].last) {
            sig[j / 64] |= std::uint64_t{1} << (j % 64);
            any = true;
          } else {
            edge = true;
          }
        }
        if (edge) {
          for (std::int64_t cell = c0; cell < c1; ++cell) edge_cells.emplace_back(cell, row);
        } else if (any) {
          groups[sig] += static_cast<double>(c1 - c0);
        }
      }
    }
    // Pass 2, the draws. Only reflecting facets are placed: a facet's position and theta are
    // independent, so thinning by p first gives the same law with fewer draws.
    const double cell_area = h_ * h_, edges = static_cast<double>(edge_cells.size());
    const auto place = [&](std::size_t cell) {  // a reflecting facet uniform in edge cell `cell`
      const double x = (static_cast<double>(edge_cells[cell].first) + rng.uniform()) * h_;
      const double y = (static_cast<double>(edge_cells[cell].second) + rng.uniform()) * h_;
      for (std::size_t j = 0; j < m; ++j)
        if (fps_[j].footprint.contains(x - fps_[j].x, y - fps_[j].y)) out[j] += 1;
    };
    const auto place_anywhere = [&](double reflecting) {  // uniform over all edge cells
      for (double f = 0; f < reflecting; f += 1)
        place(std::min(edge_cells.size() - 1, static_cast<std::size_t>(rng.uniform() * edges)));
    };
    const auto add_group = [&](const std::vector<std::uint64_t>& signature, double k) {
      for (std::size_t j = 0; j < m; ++j)
        if (signature[j / 64] >> (j % 64) & 1) out[j] += k;
    };
    if (layout_ == Layout::kStratified) {
      for (std::size_t c = 0; c < edge_cells.size(); ++c)
        if (rng.uniform() < p_) place(c);
      for (const auto& [signature, cells] : groups) add_group(signature, binomial::Sampler(cells, p_)(rng));
    } else if (layout_ == Layout::kPoisson) {
      if (!edge_cells.empty()) place_anywhere(poisson::Sampler(density_ * edges * cell_area * p_)(rng));
      for (const auto& [signature, cells] : groups)
        add_group(signature, poisson::Sampler(density_ * cells * cell_area * p_)(rng));
    } else {
      // Uniform: the N facets are multinomial over regions; as a chain of conditional binomials
      // (facets in the scanned region, then in the edge cells, then group by group).
      double group_cells = 0;
      for (const auto& g : groups) group_cells += g.second;
      const double region = (edges + group_cells) * cell_area;
      double left = binomial::Sampler(density_, std::min(1.0, region))(rng);
      double left_cells = edges + group_cells;
      if (!edge_cells.empty()) {
        const double in_edges = binomial::Sampler(left, edges / left_cells)(rng);
        left -= in_edges;
        left_cells -= edges;
        place_anywhere(binomial::Sampler(in_edges, p_)(rng));
      }
      for (const auto& [signature, cells] : groups) {
        const double facets = binomial::Sampler(left, std::min(1.0, cells / left_cells))(rng);
        left -= facets;
        left_cells -= cells;
        add_group(signature, binomial::Sampler(facets, p_)(rng));
      }
    }
  }

 private:
  Layout layout_;
  double density_, p_;
  std::vector<Placed> fps_;
  std::int64_t side_, row_first_, row_last_;
  double h_;
};

// Wraps centres onto [0, 1) and moves every footprint next to the first one (its nearest image on
// the torus), so that one scan sees them together.
std::vector<Placed> gather(const std::vector<Placed>& fps) {
  std::vector<Placed> out = fps;
  for (std::size_t j = 0; j < out.size(); ++j) {
    if (!std::isfinite(out[j].x) || !std::isfinite(out[j].y))
      throw_invalid("ground_truth", "center", std::isfinite(out[j].x) ? out[j].y : out[j].x, "finite coordinates");
    out[j].x -= std::floor(out[j].x);
    out[j].y -= std::floor(out[j].y);
    if (j > 0) {
      out[j].x = out[0].x + (out[j].x - out[0].x - std::round(out[j].x - out[0].x));
      out[j].y = out[0].y + (out[j].y - out[0].y - std::round(out[j].y - out[0].y));
    }
  }
  return out;
}

// Realization r draws from the key (seed, r): counter words x = low, y = high 32 bits of r.
CounterRng realization_rng(std::uint64_t seed, std::size_t r) {
  return CounterRng(seed, static_cast<std::uint32_t>(r),
                    static_cast<std::uint32_t>(static_cast<std::uint64_t>(r) >> 32), 0, kStreamGroundTruth);
}

// Realizations are scheduled 16 at a time (their costs vary with the footprint's position).
template <class Body>
void parallel_realizations(std::size_t count, Body body) {
  detail::parallel_chunks(count, 16, 64, [&](std::size_t r0, std::size_t r1) {
    for (std::size_t r = r0; r < r1; ++r) body(r);
  });
}

}  // namespace

Coverage stratified_coverage(const Footprint& f, double x, double y, std::int64_t side) {
  const double h = 1.0 / static_cast<double>(side);
  Coverage cov;
  const auto first = static_cast<std::int64_t>(std::floor((y - f.half_height()) / h));
  const auto last = static_cast<std::int64_t>(std::floor((y + f.half_height()) / h));
  RowSpan inside, touched;
  const double cell_area = h * h;
  for (std::int64_t row = first; row <= last; ++row) {
    const double y0 = static_cast<double>(row) * h - y, y1 = y0 + h;
    row_spans(f, x, y0, y1, chord_at(f, y0), chord_at(f, y1), h, inside, touched);
    for (std::int64_t c = touched.first; c <= touched.last; ++c) {
      if (c >= inside.first && c <= inside.last) continue;
      const double x0 = static_cast<double>(c) * h - x;
      const double frac = std::clamp(f.overlap(x0, y0, x0 + h, y1) / cell_area, 0.0, 1.0);
      if (frac > 0) cov.fractions.push_back(frac);
    }
    if (inside.first <= inside.last) cov.interior += static_cast<double>(inside.last - inside.first + 1);
  }
  return cov;
}

Distribution poisson_binomial(const std::vector<double>& q, std::size_t max_support) {
  double mean = 0, var = 0;
  for (double v : q) mean += v, var += v * (1 - v);
  const double width = 12 * std::sqrt(var) + 30;
  const double lo = std::max(0.0, std::floor(mean - width)),
               hi = std::min(static_cast<double>(q.size()), std::ceil(mean + width));
  if (hi - lo + 1 > static_cast<double>(max_support))
    throw_invalid_message("ground_truth.pmf: the boundary law needs more than max_support = " +
                          std::to_string(max_support) + " support points");
  // dp[k - base] = P(S = k) over the live window [base, base + dp.size()).
  std::vector<double> dp{1.0}, next;
  double base = 0, lost_above = 0;
  std::size_t left = 0;  // cells still to add (each can raise the sum by one)
  for (double v : q) left += v > 0;
  for (double v : q) {
    if (v <= 0) continue;
    --left;
    next.assign(dp.size() + 1, 0.0);
    for (std::size_t i = 0; i < dp.size(); ++i) {
      next[i] += dp[i] * (1 - v);
      next[i + 1] += dp[i] * v;
    }
    dp.swap(next);
    // Values above hi never come back; values below lo - (cells left) can never reach lo.
    while (!dp.empty() && base + static_cast<double>(dp.size()) - 1 > hi) lost_above += dp.back(), dp.pop_back();
    std::size_t drop = 0;
    while (drop + 1 < dp.size() && base + static_cast<double>(drop) < lo - static_cast<double>(left)) ++drop;
    if (drop) {
      dp.erase(dp.begin(), dp.begin() + static_cast<std::ptrdiff_t>(drop));
      base += static_cast<double>(drop);
    }
  }
  std::vector<double> support(dp.size());
  for (std::size_t i = 0; i < dp.size(); ++i) support[i] = base + static_cast<double>(i);
  return Distribution::with_trimmed_tails(std::move(support), std::move(dp), base > 0, lost_above > 0);
}

// ---------------------------------------------------------------------------------------------
// GroundTruth

GroundTruth::GroundTruth(Layout layout, double density, Footprint footprint, double p,
                         std::optional<std::pair<double, double>> center)
    : layout_(layout), density_(density), p_(p), footprint_(footprint), center_(center) {
  check_density(layout, density);
  check_p("ground_truth", p);
  if (2 * footprint_.half_width() >= 1 || 2 * footprint_.half_height() >= 1)
    throw_invalid("ground_truth", "footprint bounding box",
                  2 * std::max(footprint_.half_width(), footprint_.half_height()),
                  "a footprint whose bounding box fits in the unit domain (side < 1)");
  if (center_) {
    auto [x, y] = *center_;
    if (!std::isfinite(x)) throw_invalid("ground_truth", "center[0]", x, "a finite coordinate");
    if (!std::isfinite(y)) throw_invalid("ground_truth", "center[1]", y, "a finite coordinate");
    center_ = std::pair{x - std::floor(x), y - std::floor(y)};
  }
  side_ = scan_grid_side(layout, density);
}

Distribution GroundTruth::pmf(std::size_t max_support, int quadrature) const {
  const double area = footprint_.area();
  if (layout_ == Layout::kUniform) return binomial::distribution(density_, std::min(1.0, area) * p_, max_support);
  if (layout_ == Layout::kPoisson) return poisson::distribution(density_ * area * p_, max_support);
  const auto law_at = [&](double x, double y) {
    const Coverage cov = stratified_coverage(footprint_, x, y, side_);
    std::vector<double> q(cov.fractions);
    for (double& v : q) v *= p_;
    return convolve(binomial::distribution(cov.interior, p_, max_support), poisson_binomial(q, max_support),
                    max_support, "ground_truth.pmf");
  };
  if (center_) return law_at(center_->first, center_->second);
  if (quadrature < 1) throw_invalid("ground_truth.pmf", "quadrature", quadrature, "an integer >= 1");
  // The law is periodic in the centre with the cell's period h: average over one cell.
  const double h = 1.0 / static_cast<double>(side_);
  std::map<double, double> mix;
  const double w = 1.0 / (static_cast<double>(quadrature) * quadrature);
  bool below = false, above = false;
  for (int i = 0; i < quadrature; ++i)
    for (int j = 0; j < quadrature; ++j) {
      const Distribution d = law_at(0.5 + h * (i + 0.5) / quadrature, 0.5 + h * (j + 0.5) / quadrature);
      for (std::size_t k = 0; k < d.size(); ++k) mix[d.support()[k]] += w * d.probs()[k];
      below = below || d.trimmed_below();
      above = above || d.trimmed_above();
    }
  std::vector<double> support, probs;
  for (auto [k, v] : mix) support.push_back(k), probs.push_back(v);
  if (support.size() > max_support)
    throw_invalid_message("ground_truth.pmf: the law needs more than max_support = " + std::to_string(max_support) +
                          " support points");
  return Distribution::with_trimmed_tails(std::move(support), std::move(probs), below, above);
}

std::vector<double> GroundTruth::sample(std::size_t count, std::uint64_t seed) const {
  std::vector<double> out(count, 0.0);
  const Placed placed{footprint_, center_ ? center_->first : 0.5, center_ ? center_->second : 0.5};
  const Scanner fixed(layout_, density_, p_, {placed});
  parallel_realizations(count, [&](std::size_t r) {
    CounterRng rng = realization_rng(seed, r);
    if (center_) {
      fixed.realize(rng, &out[r]);
    } else {
      // A uniformly random centre: only its offset within a cell matters (the grid is periodic),
      // so the scan runs near (0.5, 0.5) shifted by a random offset of at most one cell.
      const double h = 1.0 / static_cast<double>(side_);
      const Placed moved{footprint_, 0.5 + h * rng.uniform(), 0.5 + h * rng.uniform()};
      Scanner(layout_, density_, p_, {moved}).realize(rng, &out[r]);
    }
  });
  return out;
}

std::vector<double> joint_counts(Layout layout, double density, double p, const std::vector<Placed>& footprints,
                                 std::size_t count, std::uint64_t seed) {
  check_density(layout, density);
  check_p("joint_counts", p);
  if (footprints.empty()) throw_invalid_message("joint_counts: footprints is empty; expected at least one");
  const std::vector<Placed> placed = gather(footprints);
  const Scanner scanner(layout, density, p, placed);
  const std::size_t m = placed.size();
  std::vector<double> out(count * m, 0.0);
  parallel_realizations(count, [&](std::size_t r) {
    CounterRng rng = realization_rng(seed, r);
    scanner.realize(rng, out.data() + r * m);
  });
  return out;
}

}  // namespace glintlab::spatial
