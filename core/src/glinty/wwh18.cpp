// WWH18's filterable model and its discrete-flake truth (wwh18.hpp, docs/math/wwh18.md).
#include "glintlab/glinty/wwh18.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/base/rng.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "glintlab/lighting/lobes.hpp"

namespace glintlab {

namespace {

constexpr char kWhere[] = "glinty_ndf wwh18";
constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
// Random numbers: stream ids of their own in the top byte of the last Philox counter word (KPT25's
// points use 8, rng.hpp's streams stay in the low 16 bits), so no other user of a seed shares them.
// Cell and node indices enter with all their bits: the low 32 bits as counter words, the bits above as
// high_bits() in the last word (docs/math/wwh18.md#wwh18-truth).
constexpr std::uint32_t kStreamFlakes = 9;        // (block, i, j, 9 << 24 | hi12(i) << 12 | hi12(j)): block 0 = count
constexpr std::uint32_t kStreamLambda = 10;       // (k, i, j, 10 << 24 | level << 16 | hi8(i) << 8 | hi8(j))
constexpr std::uint32_t kStreamPixelLambda = 11;  // eq. 8's lambda(x) per pixel, keyed by the bits of uv
// A pixel whose footprint's bounding box covers more base cells than this is refused (the cost of the
// truth and of the traversal grows with the flakes in the footprint; an unbounded call would seem to hang).
constexpr double kMaxCells = 1e8;

inline double unit32(std::uint32_t w) { return (static_cast<double>(w) + 0.5) * 0x1.0p-32; }
inline double unit53(std::uint32_t hi, std::uint32_t lo) {
  const std::uint64_t bits = (static_cast<std::uint64_t>(hi) << 32) | lo;
  return (static_cast<double>(bits >> 11) + 0.5) * 0x1.0p-53;
}

// The bits of a cell index above its low 32, offset so that every index in [-2^31, 2^31) gives 0 (those
// cells keep the counters of the 32-bit layout before issue 37), masked to `bits` bits: with the low 32
// bits, distinct for every index within 2^(30 + bits) of the origin (2^38 for the 8 bits of lambda).
std::uint32_t high_bits(std::int64_t i, int bits) {
  return static_cast<std::uint32_t>((i + (std::int64_t{1} << 31)) >> 32) & ((std::uint32_t{1} << bits) - 1u);
}

std::array<std::uint32_t, 4> flake_block(std::uint64_t seed, std::int64_t i, std::int64_t j, std::uint32_t block) {
  return CounterRng::block({block, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j),
                            (kStreamFlakes << 24) | (high_bits(i, 12) << 12) | high_bits(j, 12)},
                           {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)});
}

// D(m)(m.n) for an isotropic target as a function of c = m.n > 0 (the density of normals per steradian).
double projected_d(GlintTarget t, double alpha, double c) {
  if (!(c > 0.0)) return 0.0;
  const double a2 = alpha * alpha, c2 = c * c;
  if (t == GlintTarget::beckmann) {
    const double tan2 = (1.0 - c2) / c2;
    return std::exp(-tan2 / a2) / (kPi * a2 * c2 * c);
  }
  const double q = c2 * (a2 - 1.0) + 1.0;
  return a2 * c / (kPi * q * q);
}

void normalise(const double in[3], double out[3]) {
  const double n = std::sqrt(in[0] * in[0] + in[1] * in[1] + in[2] * in[2]);
  for (int c = 0; c < 3; ++c) out[c] = in[c] / n;
}

}  // namespace

void tea_encrypt(std::uint32_t& v0, std::uint32_t& v1, const std::uint32_t k[4], int rounds) {
  std::uint32_t sum = 0;
  constexpr std::uint32_t delta = 0x9e3779b9u;
  for (int r = 0; r < rounds; ++r) {
    sum += delta;
    v0 += ((v1 << 4) + k[0]) ^ (v1 + sum) ^ ((v1 >> 5) + k[1]);
    v1 += ((v0 << 4) + k[2]) ^ (v0 + sum) ^ ((v0 >> 5) + k[3]);
  }
}

double wwh18_theta_cdf(GlintTarget target, double alpha, double theta) {
  if (!(theta > 0.0)) return 0.0;
  if (theta >= 0.5 * kPi) return 1.0;
  const double t = std::tan(theta), t2 = t * t, a2 = alpha * alpha;
  // Beckmann: tan^2(theta) / alpha^2 is exponential(1) under D(m)(m.n); GGX: F = tan^2 / (alpha^2 + tan^2).
  if (target == GlintTarget::beckmann) return -std::expm1(-t2 / a2);
  return t2 / (a2 + t2);
}

// The footprint of one pixel: the parallelogram uv + a c1 + b c2, a, b in [-1/2, 1/2).
struct Wwh18Ndf::Footprint {
  double u = 0, v = 0, c1x = 0, c1y = 0, c2x = 0, c2y = 0, area = 0;
  double ia = 0, ib = 0, ic = 0, id = 0;  // inverse of [[c1x, c2x], [c1y, c2y]]
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;

  Footprint(double uu, double vv, const double* J, std::size_t index) : u(uu), v(vv) {
    c1x = J[0];
    c1y = J[1];
    c2x = J[2];
    c2y = J[3];
    const double det = c1x * c2y - c2x * c1y;
    const double scale = std::max(std::hypot(c1x, c1y), std::hypot(c2x, c2y));
    if (!(std::abs(det) > 1e-12 * scale * scale) || !(std::abs(det) > 0.0))
      throw_invalid(kWhere, indexed_name("J", 4 * index, true), det,
                    "a footprint with det J != 0 and anisotropy below 1e12 (mask pixels that do not see the surface)");
    area = std::abs(det);
    ia = c2y / det;
    ib = -c2x / det;
    ic = -c1y / det;
    id = c1x / det;
    const double hx = 0.5 * (std::abs(c1x) + std::abs(c2x)), hy = 0.5 * (std::abs(c1y) + std::abs(c2y));
    xmin = u - hx;
    xmax = u + hx;
    ymin = v - hy;
    ymax = v + hy;
  }
  // Half-open in a and b, so that footprints tiling the plane count every flake once.
  bool inside(double x, double y) const {
    const double dx = x - u, dy = y - v, a = ia * dx + ib * dy, b = ic * dx + id * dy;
    return a >= -0.5 && a < 0.5 && b >= -0.5 && b < 0.5;
  }
  bool inside_closed(double x, double y) const {
    const double dx = x - u, dy = y - v, a = ia * dx + ib * dy, b = ic * dx + id * dy;
    return a >= -0.5 && a <= 0.5 && b >= -0.5 && b <= 0.5;
  }
  // Area of the parallelogram inside the square [x0, x0 + s] x [y0, y0 + s] (Sutherland-Hodgman
  // clipping of a convex polygon, coordinates relative to the square's corner against cancellation).
  double overlap(double x0, double y0, double s) const {
    std::array<double, 16> px{}, py{}, qx{}, qy{};
    const double cu = u - x0, cv = v - y0;
    int n = 4;
    px[0] = cu - 0.5 * c1x - 0.5 * c2x, py[0] = cv - 0.5 * c1y - 0.5 * c2y;
    px[1] = cu + 0.5 * c1x - 0.5 * c2x, py[1] = cv + 0.5 * c1y - 0.5 * c2y;
    px[2] = cu + 0.5 * c1x + 0.5 * c2x, py[2] = cv + 0.5 * c1y + 0.5 * c2y;
    px[3] = cu - 0.5 * c1x + 0.5 * c2x, py[3] = cv - 0.5 * c1y + 0.5 * c2y;
    for (int edge = 0; edge < 4 && n > 0; ++edge) {
      // edge 0: x >= 0, 1: x <= s, 2: y >= 0, 3: y <= s; signed distance inside >= 0.
      auto dist = [&](double x, double y) {
        switch (edge) {
          case 0: return x;
          case 1: return s - x;
          case 2: return y;
          default: return s - y;
        }
      };
      int m = 0;
      for (int k = 0; k < n; ++k) {
        const int l = (k + 1) % n;
        const double dk = dist(px[k], py[k]), dl = dist(px[l], py[l]);
        if (dk >= 0) { qx[m] = px[k], qy[m] = py[k], ++m; }
        if ((dk >= 0) != (dl >= 0)) {
          const double t = dk / (dk - dl);
          qx[m] = px[k] + t * (px[l] - px[k]), qy[m] = py[k] + t * (py[l] - py[k]), ++m;
        }
      }
      n = m;
      px = qx;
      py = qy;
    }
    double a = 0.0;
    for (int k = 0; k < n; ++k) {
      const int l = (k + 1) % n;
      a += px[k] * py[l] - px[l] * py[k];
    }
    return std::min(0.5 * std::abs(a), s * s);
  }
};

Wwh18Ndf::Wwh18Ndf(const Wwh18Params& params) : p_(params) {
  if (!(p_.density > 0.0 && p_.density <= 1e18)) throw_invalid(kWhere, "density", p_.density, "a number in (0, 1e18]");
  if (!(p_.alpha > 0.0 && p_.alpha <= 10.0)) throw_invalid(kWhere, "alpha", p_.alpha, "a number in (0, 10]");
  // Below 1e-100 degrees the cone's solid angle, about 1e-203, nears the end of the double range.
  if (!(p_.gamma_deg >= 1e-100 && p_.gamma_deg <= 90.0))
    throw_invalid(kWhere, "gamma", p_.gamma_deg, "a cone half-angle in [1e-100, 90] degrees");
  if (p_.cone == WwhCone::outgoing && p_.dpf == WwhDpf::table)
    throw_invalid(kWhere, "cone", std::string("outgoing"),
                  "\"half_vector\" with dpf \"table\" (the outgoing cone's table is not built: dpf \"exact\")");
  if (!(p_.flakes_per_cell > 0.0 && p_.flakes_per_cell <= 64.0))
    throw_invalid(kWhere, "flakes_per_cell", p_.flakes_per_cell, "a number in (0, 64]");
  if (!(p_.tea_rounds >= 1 && p_.tea_rounds <= 64))
    throw_invalid(kWhere, "tea_rounds", static_cast<double>(p_.tea_rounds), "an integer in [1, 64]");
  if (!(p_.error_eps >= 0.0 && std::isfinite(p_.error_eps)))
    throw_invalid(kWhere, "error_eps", p_.error_eps, "a finite number >= 0");
  if (!(p_.T > 0.0)) throw_invalid(kWhere, "T", p_.T, "a number > 0 (infinity: never filter)");
  const double per90 = 90.0 / p_.table_res_deg;
  if (!(p_.table_res_deg >= 0.25 && p_.table_res_deg <= 90.0) || std::abs(per90 - std::round(per90)) > 1e-9)
    throw_invalid(kWhere, "table_res", p_.table_res_deg, "a resolution in [0.25, 90] degrees dividing 90");
  bool lod_ok = p_.lod_deg == 0.0;
  for (double l : kWwhLodLevels) lod_ok = lod_ok || p_.lod_deg == l;
  if (!lod_ok)
    throw_invalid(kWhere, "lod", p_.lod_deg, "0 (no blur) or one of 1, 2, 5, 10, 20, 30, 45, 60, 90 degrees");
  s0_ = std::sqrt(p_.flakes_per_cell / p_.density);
  cos_gamma_ = std::cos(p_.gamma_deg * kDeg);
  // 2 pi (1 - cos gamma) written without its cancellation: 1 - cos gamma rounds to 0 below 1e-7 degrees.
  const double half = std::sin(0.5 * p_.gamma_deg * kDeg);
  chord2_ = 4.0 * half * half;
  cone_solid_angle_ = kPi * chord2_;
  build_cells();
  if (p_.dpf == WwhDpf::table) {
    build_table();
    if (p_.lod_deg > 0.0) blur_table();
  }
}

double Wwh18Ndf::band_mass(double t0, double t1) const {
  return wwh18_theta_cdf(p_.target, p_.alpha, t1) - wwh18_theta_cdf(p_.target, p_.alpha, t0);
}

double Wwh18Ndf::cone_mass(const double hin[3]) const {
  double h[3];
  normalise(hin, h);
  const double ch = std::clamp(h[2], -1.0, 1.0), sh = std::sqrt(std::max(0.0, 1.0 - ch * ch));
  const double gamma = p_.gamma_deg * kDeg;
  // m(beta, psi) = cos(beta) h + sin(beta) (cos(psi) t1 + sin(psi) t2) with t1 in the plane of h and the
  // normal, pointing away from it: m.n = cos(beta) ch - sin(beta) sh cos(psi). The integrand only depends
  // on m.n (isotropic target), so psi runs over [0, pi] twice; psi is cut where m.n reaches 0.
  using GK = boost::math::quadrature::gauss_kronrod<double, 31>;
  auto outer = [&](double beta) {
    const double cb = std::cos(beta), sb = std::sin(beta);
    if (sb == 0.0) return 0.0;
    double psi_max = kPi;
    if (sh > 0.0) {
      const double c = cb * ch / (sb * sh);  // m.n > 0 <=> cos(psi) < c
      if (c <= -1.0) return 0.0;
      if (c < 1.0) psi_max = std::acos(c);
    } else if (ch <= 0.0) {
      return 0.0;
    }
    auto inner = [&](double psi) { return projected_d(p_.target, p_.alpha, cb * ch - sb * sh * std::cos(psi)); };
    return 2.0 * sb * GK::integrate(inner, 0.0, psi_max, 12, 1e-11);
  };
  return std::clamp(GK::integrate(outer, 0.0, gamma, 12, 1e-11), 0.0, 1.0);
}

double Wwh18Ndf::outgoing_cone_mass(const double wiin[3], const double woin[3]) const {
  double wi[3], wo[3];
  normalise(wiin, wi);
  normalise(woin, wo);
  // A frame (t1, t2) around wo; w(beta, psi) = cos(beta) wo + sin(beta) (cos(psi) t1 + sin(psi) t2), the
  // outgoing directions of the cone, and h' = normalise(wi + w) the normal that reflects wi into w:
  // dOmega_h' = dOmega_w / (4 wi.h'), so the normals' mass is the cone's integral of D(h')(h'.n) / (4 wi.h').
  const double a[3] = {std::abs(wo[0]) < 0.9 ? 1.0 : 0.0, std::abs(wo[0]) < 0.9 ? 0.0 : 1.0, 0.0};
  double t1[3] = {a[1] * wo[2] - a[2] * wo[1], a[2] * wo[0] - a[0] * wo[2], a[0] * wo[1] - a[1] * wo[0]};
  normalise(t1, t1);
  const double t2[3] = {wo[1] * t1[2] - wo[2] * t1[1], wo[2] * t1[0] - wo[0] * t1[2], wo[0] * t1[1] - wo[1] * t1[0]};
  using GK = boost::math::quadrature::gauss_kronrod<double, 31>;
  auto outer = [&](double beta) {
    const double cb = std::cos(beta), sb = std::sin(beta);
    if (sb == 0.0) return 0.0;
    auto inner = [&](double psi) {
      const double cp = std::cos(psi), sp = std::sin(psi);
      double h[3];
      for (int c = 0; c < 3; ++c) h[c] = wi[c] + cb * wo[c] + sb * (cp * t1[c] + sp * t2[c]);
      const double len = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
      if (!(len > 1e-12)) return 0.0;  // w = -wi: no normal reflects wi there
      const double d = (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]) / len;
      return projected_d(p_.target, p_.alpha, h[2] / len) / (4.0 * d);
    };
    return sb * GK::integrate(inner, 0.0, 2.0 * kPi, 12, 1e-11);
  };
  return std::clamp(GK::integrate(outer, 0.0, p_.gamma_deg * kDeg, 12, 1e-11), 0.0, 1.0);
}

void Wwh18Ndf::build_cells() {
  // The hemisphere grid of the 1-degree (table_res) table: bands of theta_m, cells of phi_m; a cell's
  // mass is its band's mass (closed-form CDF of theta_m) times its share of 2 pi.
  const int nt = static_cast<int>(std::lround(90.0 / p_.table_res_deg));
  const int nphi = 4 * nt;
  const double res = p_.table_res_deg * kDeg;
  band_ct_.resize(nt);
  band_st_.resize(nt);
  band_mass_.resize(nt);
  for (int k = 0; k < nt; ++k) {
    const double tc = (k + 0.5) * res;
    band_ct_[k] = std::cos(tc);
    band_st_[k] = std::sin(tc);
    band_mass_[k] = band_mass(k * res, (k + 1) * res) / nphi;
  }
}

double Wwh18Ndf::accumulated(const double hin[3]) const {
  double h[3];
  normalise(hin, h);
  const double ch = std::clamp(h[2], -1.0, 1.0), sh = std::sqrt(std::max(0.0, 1.0 - ch * ch));
  const double th = std::acos(ch);
  const double ph = std::atan2(h[1], h[0]);
  const double res = p_.table_res_deg * kDeg, gamma = p_.gamma_deg * kDeg;
  const int nt = static_cast<int>(band_ct_.size());
  const long nphi = 4L * nt;  // phi cells per band
  double sum = 0.0;
  const int k0 = std::max(0, static_cast<int>(std::floor((th - gamma) / res - 0.5)) - 1);
  const int k1 = std::min(nt - 1, static_cast<int>(std::ceil((th + gamma) / res - 0.5)) + 1);
  for (int k = k0; k <= k1; ++k) {
    const double ct = band_ct_[k], st = band_st_[k];
    // Cells of band k whose centre (theta_c, phi) lies within gamma of h: cos(phi - phi_h) >= c.
    double half_width;
    if (sh * st == 0.0) {
      half_width = ct * ch >= cos_gamma_ ? kPi : -1.0;
    } else {
      const double c = (cos_gamma_ - ct * ch) / (st * sh);
      half_width = c <= -1.0 ? kPi : (c > 1.0 ? -1.0 : std::acos(c));
    }
    if (half_width < 0.0) continue;
    if (half_width >= kPi) {  // the whole band
      sum += band_mass_[k] * static_cast<double>(nphi);
      continue;
    }
    // The cells inside are those whose centre angle (l + 1/2) res lies in [phi_h - w, phi_h + w]: a
    // contiguous run of indices (2 w < 2 pi here), counted without visiting them.
    const double lo = std::ceil((ph - half_width) / res - 0.5), hi = std::floor((ph + half_width) / res - 0.5);
    const double inside = std::clamp(hi - lo + 1.0, 0.0, static_cast<double>(nphi));
    sum += band_mass_[k] * inside;
  }
  return std::min(sum, 1.0);
}

void Wwh18Ndf::build_table() {
  // Nodes every table_res degrees: theta_i, theta_o in [0, 90], dphi in [0, 180] (both ends included).
  const int nt = static_cast<int>(std::lround(90.0 / p_.table_res_deg)) + 1;
  dims_[0] = nt;
  dims_[1] = nt;
  dims_[2] = 2 * (nt - 1) + 1;
  table_.assign(static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2], 0.0);
  const double res = p_.table_res_deg * kDeg;
  detail::parallel_chunks(static_cast<std::size_t>(nt), 1, 2, [&](std::size_t first, std::size_t last) {
    for (std::size_t a = first; a < last; ++a) {
      const double ti = static_cast<double>(a) * res;
      const double wi[3] = {std::sin(ti), 0.0, std::cos(ti)};
      for (int b = 0; b < dims_[1]; ++b) {
        const double to = b * res;
        for (int c = 0; c < dims_[2]; ++c) {
          const double dp = c * res;
          const double wo[3] = {std::sin(to) * std::cos(dp), std::sin(to) * std::sin(dp), std::cos(to)};
          const double hs[3] = {wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]};
          const double len = std::sqrt(hs[0] * hs[0] + hs[1] * hs[1] + hs[2] * hs[2]);
          double value = len > 1e-9 ? accumulated(hs) : 0.0;  // wi = -wo (both grazing): no half vector
          if (p_.float32) value = static_cast<double>(static_cast<float>(value));
          table_[(a * dims_[1] + b) * dims_[2] + c] = value;
        }
      }
    }
  });
}

void Wwh18Ndf::blur_table() {
  // Separable Gaussian, std lod_deg, truncated at 3 std and renormalised. theta axes: the edge value
  // repeated; dphi: reflected at 0 and 180 degrees (P is even and 360-periodic in dphi).
  const double sigma = p_.lod_deg / p_.table_res_deg;
  for (int axis = 0; axis < 3; ++axis) {
    const int n = dims_[axis];
    const int radius = static_cast<int>(std::ceil(3.0 * sigma));
    std::vector<double> w(2 * radius + 1);
    double wsum = 0.0;
    for (int r = -radius; r <= radius; ++r) wsum += w[r + radius] = std::exp(-0.5 * r * r / (sigma * sigma));
    for (double& x : w) x /= wsum;
    const std::size_t stride = axis == 0 ? static_cast<std::size_t>(dims_[1]) * dims_[2]
                                         : (axis == 1 ? static_cast<std::size_t>(dims_[2]) : 1);
    const std::size_t lines = table_.size() / n;
    std::vector<double> out(table_.size());
    detail::parallel_chunks(lines, 64, 128, [&](std::size_t first, std::size_t last) {
      std::vector<double> line(n);
      for (std::size_t q = first; q < last; ++q) {
        // Line q: its base index with the axis coordinate 0.
        const std::size_t outer = q / stride, inner = q % stride;
        const std::size_t base = outer * stride * n + inner;
        for (int x = 0; x < n; ++x) line[x] = table_[base + x * stride];
        for (int x = 0; x < n; ++x) {
          double s = 0.0;
          for (int r = -radius; r <= radius; ++r) {
            int y = x + r;
            if (axis == 2) {
              const int period = 2 * (n - 1);
              y = ((y % period) + period) % period;
              if (y >= n) y = period - y;
            } else {
              y = std::clamp(y, 0, n - 1);
            }
            s += w[r + radius] * line[y];
          }
          out[base + x * stride] = p_.float32 ? static_cast<double>(static_cast<float>(s)) : s;
        }
      }
    });
    table_.swap(out);
  }
}

double Wwh18Ndf::dpf(const double wiin[3], const double woin[3]) const {
  if (table_.empty()) return 0.0;
  double wi[3], wo[3];
  normalise(wiin, wi);
  normalise(woin, wo);
  if (!(wi[2] > 0.0) || !(wo[2] > 0.0)) return 0.0;
  const double ti = std::acos(std::min(1.0, wi[2])) / kDeg, to = std::acos(std::min(1.0, wo[2])) / kDeg;
  double dp = 0.0;
  if (std::hypot(wi[0], wi[1]) > 0.0 && std::hypot(wo[0], wo[1]) > 0.0)
    dp = std::abs(std::remainder(std::atan2(wi[1], wi[0]) - std::atan2(wo[1], wo[0]), 2.0 * kPi)) / kDeg;
  const double x[3] = {ti / p_.table_res_deg, to / p_.table_res_deg, dp / p_.table_res_deg};
  int i0[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    const double xc = std::clamp(x[a], 0.0, static_cast<double>(dims_[a] - 1));
    i0[a] = std::min(static_cast<int>(std::floor(xc)), dims_[a] - 2);
    f[a] = xc - i0[a];
  }
  double value = 0.0;
  for (int c = 0; c < 8; ++c) {
    double w = 1.0;
    std::size_t idx = 0;
    for (int a = 0; a < 3; ++a) {
      const int bit = (c >> a) & 1;
      w *= bit ? f[a] : 1.0 - f[a];
      idx = idx * dims_[a] + static_cast<std::size_t>(i0[a] + bit);
    }
    value += w * table_[idx];
  }
  return value;
}

double Wwh18Ndf::model_p(const double hin[3], const double* wiin) const {
  double h[3];
  normalise(hin, h);
  if (!(h[2] > 0.0)) return 0.0;
  if (p_.dpf == WwhDpf::exact && p_.cone == WwhCone::half_vector) return cone_mass(h);
  if (!wiin && p_.cone == WwhCone::half_vector)
    return dpf(h, h);  // no light direction given: wi = wo = h (theta_i = theta_o, dphi = 0)
  double wi[3];
  normalise(wiin ? wiin : h, wi);
  const double d = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
  const double wo[3] = {2 * d * h[0] - wi[0], 2 * d * h[1] - wi[1], 2 * d * h[2] - wi[2]};
  if (p_.cone == WwhCone::outgoing) return outgoing_cone_mass(wi, wo);  // dpf exact (the constructor)
  return dpf(wi, wo);
}

double Wwh18Ndf::lambda(std::uint64_t seed, int level, std::int64_t i, std::int64_t j, std::uint32_t k) const {
  if (p_.rng == WwhRng::tea) {
    // TEA as JHY14 and WWH18 use it: a 32-bit node id and the flake index as the 64-bit block, the seed
    // and the level as the key. The node id packs (i, j) as i + 2^16 j, so horizontally adjacent nodes
    // have adjacent ids; that id alone repeats for nodes 2^16 apart, so the key also carries the bits
    // of i and j above their low 16 (offset by 2^15: nodes in [-2^15, 2^15)^2 keep the key of the 32-bit
    // id, 0x9e3779b9), and every node within 2^38 of the origin has its own (id, key).
    const auto upper = [](std::int64_t x) {
      return static_cast<std::uint32_t>((x + (std::int64_t{1} << 15)) >> 16) & 0xffffffu;
    };
    std::uint32_t v0 = static_cast<std::uint32_t>(i) + (static_cast<std::uint32_t>(j) << 16), v1 = k;
    const std::uint32_t key[4] = {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                                  static_cast<std::uint32_t>(level) | (upper(j) << 8), 0x9e3779b9u ^ upper(i)};
    tea_encrypt(v0, v1, key, p_.tea_rounds);
    return unit32(v0);
  }
  const auto r = CounterRng::block(
      {k, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j),
       (kStreamLambda << 24) | (static_cast<std::uint32_t>(level) << 16) | (high_bits(i, 8) << 8) | high_bits(j, 8)},
      {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)});
  return unit32(r[0]);
}

double Wwh18Ndf::pixel_lambda(std::uint64_t seed, double u, double v) const {
  // Two Philox blocks: the 128 bits of (u, v) hashed, then the hash with this stream's id (whatever rng).
  const std::array<std::uint32_t, 2> key = {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)};
  const auto bu = std::bit_cast<std::uint64_t>(u), bv = std::bit_cast<std::uint64_t>(v);
  const auto r = CounterRng::block({static_cast<std::uint32_t>(bu), static_cast<std::uint32_t>(bu >> 32),
                                    static_cast<std::uint32_t>(bv), static_cast<std::uint32_t>(bv >> 32)},
                                   key);
  return unit32(CounterRng::block({r[0], r[1], r[2], kStreamPixelLambda << 24}, key)[0]);
}

std::uint32_t Wwh18Ndf::cell_count(std::uint64_t seed, std::int64_t i, std::int64_t j) const {
  // Poisson(flakes_per_cell) by inversion of one uniform (the mean is at most 64: exp(-mean) is normal).
  const auto r = flake_block(seed, i, j, 0);
  const double u = unit53(r[0], r[1]), mu = p_.flakes_per_cell;
  double prob = std::exp(-mu), cdf = prob;
  std::uint32_t k = 0;
  const double cap = mu + 40.0 * std::sqrt(mu) + 40.0;
  while (u > cdf && k < cap) {
    ++k;
    prob *= mu / k;
    cdf += prob;
  }
  return k;
}

bool Wwh18Ndf::passes(double psi, double p) const {
  // eq. 8-9: H(lambda - P) as printed, H(P - lambda) flipped; H(0) = 0.
  return p_.threshold_test == WwhThresholdTest::printed ? psi > p : p > psi;
}

double Wwh18Ndf::node_pass(const Footprint&, std::uint64_t seed, int level, std::int64_t i, std::int64_t j,
                           double p) const {
  auto counts = [&](double psi) { return passes(psi, p); };
  const std::int64_t side = std::int64_t{1} << level;
  double pass = 0.0;
  if (p_.lambda_seeding == WwhLambdaSeeding::pixel) {  // the pixel's one lambda was tested by counts()
    for (std::int64_t a = 0; a < side; ++a)
      for (std::int64_t b = 0; b < side; ++b) pass += cell_count(seed, i * side + a, j * side + b);
    return pass;
  }
  if (p_.lambda_seeding == WwhLambdaSeeding::node) {
    // As printed: psi <- lambda(k) with k the node, so all |node| flakes pass or none does.
    double n = 0.0;
    for (std::int64_t a = 0; a < side; ++a)
      for (std::int64_t b = 0; b < side; ++b) n += cell_count(seed, i * side + a, j * side + b);
    if (n == 0.0) return 0.0;  // |node| = 0: pass
    return counts(lambda(seed, level, i, j, 0)) ? n : 0.0;
  }
  for (std::int64_t a = 0; a < side; ++a)
    for (std::int64_t b = 0; b < side; ++b) {
      const std::int64_t ci = i * side + a, cj = j * side + b;
      const std::uint32_t n = cell_count(seed, ci, cj);
      for (std::uint32_t k = 0; k < n; ++k) pass += counts(lambda(seed, 0, ci, cj, k)) ? 1.0 : 0.0;
    }
  return pass;
}

double Wwh18Ndf::traverse(const Footprint& fp, std::uint64_t seed, double p) const {
  // Algorithm 1 from the level whose nodes are at least as large as the footprint's bounding box
  // (Fig. 5): that box then meets at most 2 x 2 of them.
  const double extent = std::max(fp.xmax - fp.xmin, fp.ymax - fp.ymin);
  int start = std::max(0, static_cast<int>(std::ceil(std::log2(extent / s0_))));
  start = std::min(start, 40);
  struct Node {
    int level;
    std::int64_t i, j;
  };
  std::vector<Node> stack;
  const double side0 = std::ldexp(s0_, start);
  for (auto i = static_cast<std::int64_t>(std::floor(fp.xmin / side0));
       i <= static_cast<std::int64_t>(std::floor(fp.xmax / side0)); ++i)
    for (auto j = static_cast<std::int64_t>(std::floor(fp.ymin / side0));
         j <= static_cast<std::int64_t>(std::floor(fp.ymax / side0)); ++j)
      stack.push_back({start, i, j});
  const double eps_area = p_.error_eps * fp.area;
  double count = 0.0;
  while (!stack.empty()) {
    const Node nd = stack.back();
    stack.pop_back();
    const double s = std::ldexp(s0_, nd.level);
    const double x0 = static_cast<double>(nd.i) * s, y0 = static_cast<double>(nd.j) * s;
    const bool whole = fp.inside_closed(x0, y0) && fp.inside_closed(x0 + s, y0) && fp.inside_closed(x0, y0 + s) &&
                       fp.inside_closed(x0 + s, y0 + s);
    if (whole) {
      count += node_pass(fp, seed, nd.level, nd.i, nd.j, p);
      continue;
    }
    const double ov = fp.overlap(x0, y0, s);
    if (!(ov > 0.0)) continue;  // node and query disjoint
    if (nd.level == 0 || s * s <= eps_area) {
      // The error criterion holds: the fractional overlap times the node's passing flakes.
      count += ov / (s * s) * node_pass(fp, seed, nd.level, nd.i, nd.j, p);
      continue;
    }
    for (int c = 0; c < 4; ++c) stack.push_back({nd.level - 1, 2 * nd.i + (c & 1), 2 * nd.j + (c >> 1)});
  }
  return count;
}

namespace {

void check_pixel(const double* uv, const double* h, std::size_t i) {
  for (int c = 0; c < 2; ++c)
    if (!std::isfinite(uv[2 * i + c]) || std::abs(uv[2 * i + c]) > 1e9)
      throw_invalid(kWhere, indexed_name("uv", 2 * i + c, true), uv[2 * i + c], "a finite position, |uv| <= 1e9");
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(h[3 * i + c]))
      throw_invalid(kWhere, indexed_name("h", 3 * i + c, true), h[3 * i + c], "a finite half vector");
  const double* H = h + 3 * i;
  if (!(H[0] * H[0] + H[1] * H[1] + H[2] * H[2] > 1e-300))
    throw_invalid(kWhere, indexed_name("h", 3 * i, true), H[0], "a nonzero half vector");
}

void check_direction(const double* w, std::size_t i, const char* name) {
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(w[3 * i + c]))
      throw_invalid(kWhere, indexed_name(name, 3 * i + c, true), w[3 * i + c], "a finite direction");
  const double* W = w + 3 * i;
  if (!(W[0] * W[0] + W[1] * W[1] + W[2] * W[2] > 1e-300))
    throw_invalid(kWhere, indexed_name(name, 3 * i, true), W[0], "a nonzero direction");
}

void check_cells(double cells, std::size_t i) {
  if (!(cells <= kMaxCells))
    throw_invalid(kWhere, indexed_name("J", 4 * i, true), cells,
                  "a footprint covering at most 1e8 base cells (lower the density or the footprint, or filter with T)");
}

}  // namespace

void Wwh18Ndf::check_range(const Footprint& fp, std::size_t index) const {
  // The cells' random numbers carry their indices' bits within 2^38 base cells of the origin
  // (high_bits); a footprint beyond would see the cells of another place again.
  const double limit = kWwhMaxCellIndex * s0_;
  if (!(std::max({-fp.xmin, fp.xmax, -fp.ymin, fp.ymax}) < limit)) {
    const int c = std::max(-fp.xmin, fp.xmax) >= limit ? 0 : 1;
    throw_invalid(kWhere, indexed_name("uv", 2 * index + c, true), c == 0 ? fp.u : fp.v,
                  "a footprint within 2^38 base cells of the origin (|uv| < " + format_value(limit) +
                      " at this density; a lower density or uv nearer the origin)");
  }
}

bool Wwh18Ndf::flake_counts(const double m[3], const double h[3], const double wi[3], const double wo[3]) const {
  // The angle test as a chord, |a - b|^2 <= 4 sin^2(gamma / 2): no cancellation for small gamma, where
  // a.b >= cos(gamma) would compare numbers that round to 1.
  double a[3];
  const double* b = h;
  if (p_.cone == WwhCone::outgoing) {  // the reflection of wi about m, against wo
    const double d = 2.0 * (wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2]);
    for (int c = 0; c < 3; ++c) a[c] = d * m[c] - wi[c];
    b = wo;
  } else {
    for (int c = 0; c < 3; ++c) a[c] = m[c];
  }
  const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz <= chord2_;
}

template <class F>
void Wwh18Ndf::for_each_flake(const Footprint& fp, std::size_t index, std::uint64_t seed, F&& f) const {
  const double a2 = p_.alpha * p_.alpha;
  const auto i0 = static_cast<std::int64_t>(std::floor(fp.xmin / s0_)),
             i1 = static_cast<std::int64_t>(std::floor(fp.xmax / s0_));
  const auto j0 = static_cast<std::int64_t>(std::floor(fp.ymin / s0_)),
             j1 = static_cast<std::int64_t>(std::floor(fp.ymax / s0_));
  check_cells(static_cast<double>(i1 - i0 + 1) * static_cast<double>(j1 - j0 + 1), index);
  for (std::int64_t i = i0; i <= i1; ++i)
    for (std::int64_t j = j0; j <= j1; ++j) {
      const std::uint32_t n = cell_count(seed, i, j);
      for (std::uint32_t k = 0; k < n; ++k) {
        const auto r = flake_block(seed, i, j, 1 + k);
        const double x = (static_cast<double>(i) + unit32(r[0])) * s0_;
        const double y = (static_cast<double>(j) + unit32(r[1])) * s0_;
        if (!fp.inside(x, y)) continue;
        // The normal, drawn exactly from D(m)(m.n) by inverting the closed-form CDF of theta_m.
        const double u1 = unit32(r[2]), phi = 2.0 * kPi * unit32(r[3]);
        const double tan2 = p_.target == GlintTarget::beckmann ? -a2 * std::log(u1) : a2 * u1 / (1.0 - u1);
        const double ct = 1.0 / std::sqrt(1.0 + tan2), st = std::sqrt(tan2) * ct;
        const double mv[3] = {st * std::cos(phi), st * std::sin(phi), ct};
        f(mv);
      }
    }
}

void Wwh18Ndf::reference_counts(const double* uv, const double* jac, const double* h, std::size_t m, std::uint64_t seed,
                                double* out, const double* wi) const {
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t px = first; px < last; ++px) {
      check_pixel(uv, h, px);
      if (wi) check_direction(wi, px, "wi");
      const Footprint fp(uv[2 * px], uv[2 * px + 1], jac + 4 * px, px);
      check_range(fp, px);
      double hn[3], wn[3], wo[3];
      normalise(h + 3 * px, hn);
      if (!(hn[2] > 0.0)) {
        out[px] = 0.0;
        continue;
      }
      normalise(wi ? wi + 3 * px : hn, wn);  // the light direction (wi = h: wo = h)
      const double d = 2.0 * (wn[0] * hn[0] + wn[1] * hn[1] + wn[2] * hn[2]);
      for (int c = 0; c < 3; ++c) wo[c] = d * hn[c] - wn[c];
      double count = 0.0;
      for_each_flake(fp, px, seed, [&](const double* mv) {
        if (flake_counts(mv, hn, wn, wo)) count += 1.0;
      });
      out[px] = count;
    }
  });
}

void Wwh18Ndf::cone_counts(const lighting::LightHit& hit, const lighting::GlintLightOptions& opt,
                           const lighting::LightNodes& nodes, const double v[3], const double m[3],
                           std::vector<char>& light_rule, double* c, double& radiance) const {
  using lighting::Vec3;
  const bool outgoing = p_.cone == WwhCone::outgoing;
  const double vm = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];
  // The cone's centre: the normal (a cone of half vectors) or its mirror direction of the view (a cone of
  // directions of light, the outgoing cone reflected about m: reflection keeps angles).
  Vec3 ctr{m[0], m[1], m[2]};
  if (outgoing) {
    if (!(vm > 0.0)) return;
    ctr = {2.0 * vm * m[0] - v[0], 2.0 * vm * m[1] - v[1], 2.0 * vm * m[2] - v[2]};
  }
  const double gamma = p_.gamma_deg * kDeg, density = opt.unnormalised ? 1.0 : 1.0 / cone_solid_angle_;
  // The cone's radius in directions of light: gamma, or about 2 gamma for a cone of half vectors.
  const double r_lobe = outgoing ? gamma : 2.0 * gamma;
  const int lights = hit.is_map() ? 0 : static_cast<int>(hit.lights().size());
  bool any_lobe_rule = lights == 0 || !opt.mirror;
  for (int k = 0; k < lights; ++k) {
    light_rule[k] = opt.mirror && nodes.radius[k] < r_lobe;
    if (!light_rule[k]) {
      any_lobe_rule = true;
      continue;
    }
    const double s = cone_over_light(hit, nodes, k, opt.rule.rings, v, ctr);
    c[k] += density * s;
    radiance += density * s * hit.light_radiance(k);
  }
  if (!any_lobe_rule) return;
  // The cone's rule: cells of equal solid angle (rings x sectors), each sigma(gamma) / cells of the cone.
  const int rings = opt.rule.rings, sectors = opt.rule.sectors;
  const double w = density * cone_solid_angle_ / (rings * sectors);
  Vec3 t1, t2;
  lighting::tangent_frame(ctr, t1, t2);
  for (int r = 0; r < rings; ++r) {
    const double rho = lighting::cap_ring_angle(r, rings, gamma);
    for (int s = 0; s < sectors; ++s) {
      const Vec3 d = lighting::polar_direction(ctr, t1, t2, rho, 2.0 * kPi * (s + 0.5) / sectors);
      double a[3] = {d.x, d.y, d.z};
      if (outgoing) {  // the normal that mirrors v into d
        const double sum[3] = {v[0] + d.x, v[1] + d.y, v[2] + d.z};
        if (!(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2] > 1e-24)) continue;
        normalise(sum, a);
      }
      double rad = 0.0;
      const int k = hit.hit({v[0], v[1], v[2]}, {a[0], a[1], a[2]}, rad, opt.mirror);
      if (k < 0 || (k < lights && light_rule[k])) continue;
      c[k] += w;
      radiance += w * rad;
    }
  }
}

double Wwh18Ndf::cone_over_light(const lighting::LightHit& hit, const lighting::LightNodes& nodes, int k, int rings,
                                 const double v[3], const lighting::Vec3& ctr) const {
  using lighting::Vec3;
  const bool outgoing = p_.cone == WwhCone::outgoing;
  const double gamma = p_.gamma_deg * kDeg;
  const Vec3 c = nodes.centre[k];
  // The cone in directions of light: within gamma of ctr (outgoing), or within 2 gamma of the mirror direction
  // of v about m (a reflection about h moves by at most twice the angle h moves): far from the light, nothing.
  Vec3 mid = ctr;
  if (!outgoing) {
    const double vm = v[0] * ctr.x + v[1] * ctr.y + v[2] * ctr.z;
    mid = {2.0 * vm * ctr.x - v[0], 2.0 * vm * ctr.y - v[1], 2.0 * vm * ctr.z - v[2]};
  }
  const double cos_gap = std::clamp(mid.x * c.x + mid.y * c.y + mid.z * c.z, -1.0, 1.0);
  if (std::acos(cos_gap) > nodes.radius[k] + (outgoing ? 1.0 : 2.0) * gamma + 1e-9) return 0.0;
  const auto& lights = hit.lights();
  // The integrand on the ray at angle rho: inside the cone (and in no earlier light), times the Jacobian
  // 1 / (4 v.h) of a cone of half vectors.
  double edge = 0.0;  // the last value's |a - ctr|^2 - chord^2: continuous, negative inside the cone
  auto value = [&](Vec3 w, bool& inside) {
    inside = false;
    edge = 1.0;
    double a[3] = {w.x, w.y, w.z}, jac = 1.0;
    if (!outgoing) {
      const double sum[3] = {v[0] + w.x, v[1] + w.y, v[2] + w.z};
      if (!(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2] > 1e-24)) return 0.0;
      normalise(sum, a);
      const double vh = v[0] * a[0] + v[1] * a[1] + v[2] * a[2];
      if (!(vh > 0.0)) return 0.0;
      jac = 1.0 / (4.0 * vh);
    }
    const double dx = a[0] - ctr.x, dy = a[1] - ctr.y, dz = a[2] - ctr.z;
    edge = dx * dx + dy * dy + dz * dz - chord2_;
    if (!(edge <= 0.0)) return 0.0;
    for (int j = 0; j < k; ++j)
      if (lights[j].contains(w)) return 0.0;
    inside = true;
    return jac;
  };
  const auto& exits = nodes.exits[k];
  const int sectors = static_cast<int>(exits.size());
  constexpr double kGx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
  constexpr double kGw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  double total = 0.0;
  for (int s = 0; s < sectors; ++s) {
    const double phi = nodes.phi[k][s], cp = std::cos(phi), sp = std::sin(phi);
    const Vec3 t1 = nodes.t1[k], t2 = nodes.t2[k];
    const Vec3 d{cp * t1.x + sp * t2.x, cp * t1.y + sp * t2.y, cp * t1.z + sp * t2.z};
    auto at = [&](double rho) {
      const double cr = std::cos(rho), sr = std::sin(rho);
      return Vec3{cr * c.x + sr * d.x, cr * c.y + sr * d.y, cr * c.z + sr * d.z};
    };
    auto piece = [&](double r0, double r1) {  // the smooth part over [r0, r1], all inside
      double sum = 0.0;
      bool inside;
      for (int g = 0; g < 3; ++g) {
        const double rho = 0.5 * (r0 + r1) + 0.5 * (r1 - r0) * kGx[g];
        sum += kGw[g] * value(at(rho), inside) * std::sin(rho);
      }
      return 0.5 * (r1 - r0) * sum;
    };
    const double rho_max = exits[s];
    double sector = 0.0;
    bool in0;
    value(at(0.0), in0);
    double e0 = edge;
    for (int r = 0; r < rings; ++r) {
      const double r0 = rho_max * r / rings, r1 = rho_max * (r + 1) / rings;
      bool in1;
      value(at(r1), in1);
      const double e1 = edge;
      if (in0 && in1) {
        sector += piece(r0, r1);
      } else if (in0 != in1) {  // one crossing in the piece assumed
        double lo = r0, hi = r1;
        if ((e0 <= 0.0) != (e1 <= 0.0)) {
          // The cone's edge: the Illinois variant of regula falsi on the continuous `edge`, to 1e-13 of the ray.
          double flo = e0, fhi = e1;
          int side = 0;
          for (int it = 0; it < 60 && hi - lo > 1e-13 * rho_max; ++it) {
            const double x = (lo * fhi - hi * flo) / (fhi - flo);
            bool in;
            value(at(x), in);
            if ((edge <= 0.0) == (flo <= 0.0)) {
              lo = x;
              flo = edge;
              if (side == -1) fhi *= 0.5;
              side = -1;
            } else {
              hi = x;
              fhi = edge;
              if (side == 1) flo *= 0.5;
              side = 1;
            }
            if (edge == 0.0) lo = hi = x;
          }
        } else {  // an earlier light's edge (or the half vector turning away): bisection on the indicator
          for (int it = 0; it < 60 && hi - lo > 1e-12 * rho_max; ++it) {
            const double mid_rho = 0.5 * (lo + hi);
            bool in;
            value(at(mid_rho), in);
            (in == in0 ? lo : hi) = mid_rho;
          }
        }
        sector += in0 ? piece(r0, lo) : piece(hi, r1);
      }
      in0 = in1;
      e0 = e1;
    }
    total += nodes.phi_weight[k][s] * sector;
  }
  return total;
}

void Wwh18Ndf::light_counts(const double* uv, const double* jac, const double* wo, std::size_t m, std::uint64_t seed,
                            const lighting::LightHit& hit, const lighting::GlintLightOptions& opt, double* counts,
                            double* radiance, double* flakes) const {
  const int channels = hit.channels();
  const bool lobes = opt.lit_as == lighting::GlintLight::kLobe;
  const lighting::LightNodes nodes = lobes ? lighting::light_nodes(hit, opt.rule) : lighting::LightNodes{};
  detail::parallel_chunks(m, 1, 4, [&](std::size_t first, std::size_t last) {
    std::vector<char> light_rule(hit.is_map() ? 0 : hit.lights().size(), 0);
    for (std::size_t px = first; px < last; ++px) {
      for (int c = 0; c < 2; ++c)
        if (!std::isfinite(uv[2 * px + c]) || std::abs(uv[2 * px + c]) > 1e9)
          throw_invalid(kWhere, indexed_name("uv", 2 * px + c, true), uv[2 * px + c], "a finite position, |uv| <= 1e9");
      check_direction(wo, px, "wo");
      double v[3];
      normalise(wo + 3 * px, v);
      if (!(v[2] > 0.0)) throw_invalid(kWhere, indexed_name("wo", 3 * px + 2, true), v[2], "a view above the horizon");
      const Footprint fp(uv[2 * px], uv[2 * px + 1], jac + 4 * px, px);
      check_range(fp, px);
      double* c = counts + px * static_cast<std::size_t>(channels);
      for (int k = 0; k < channels; ++k) c[k] = 0.0;
      radiance[px] = flakes[px] = 0.0;
      for_each_flake(fp, px, seed, [&](const double* mv) {
        flakes[px] += 1.0;
        if (lobes) {
          cone_counts(hit, opt, nodes, v, mv, light_rule, c, radiance[px]);
          return;
        }
        double rad = 0.0;
        const int k = hit.hit({v[0], v[1], v[2]}, {mv[0], mv[1], mv[2]}, rad, opt.mirror);
        if (k < 0) return;
        c[k] += 1.0;
        radiance[px] += rad;
      });
    }
  });
}

void Wwh18Ndf::counts(const double* uv, const double* jac, const double* h, const double* wi, std::size_t m,
                      std::uint64_t seed, double* out, int* mode, double* p_out) const {
  detail::parallel_chunks(m, 8, 16, [&](std::size_t first, std::size_t last) {
    for (std::size_t px = first; px < last; ++px) {
      check_pixel(uv, h, px);
      if (wi) check_direction(wi, px, "wi");
      const Footprint fp(uv[2 * px], uv[2 * px + 1], jac + 4 * px, px);
      check_range(fp, px);
      const double p = model_p(h + 3 * px, wi ? wi + 3 * px : nullptr);
      if (p_out) p_out[px] = p;
      const double mean = p_.density * fp.area * p;  // eq. 10's expected glint count N a(A) P
      if (!(p > 0.0)) {
        out[px] = 0.0;
        if (mode) mode[px] = kWwhZero;
      } else if (mean > p_.T) {
        out[px] = mean;  // the filtered model (eq. 10), the threshold rule of the `threshold` law
        if (mode) mode[px] = kWwhFiltered;
      } else {
        check_cells((fp.xmax - fp.xmin) * (fp.ymax - fp.ymin) / (s0_ * s0_), px);
        // lambda per pixel (eq. 8's lambda(x)): one test for the whole footprint, all flakes or none.
        const bool pass =
            p_.lambda_seeding != WwhLambdaSeeding::pixel || passes(pixel_lambda(seed, uv[2 * px], uv[2 * px + 1]), p);
        out[px] = pass ? traverse(fp, seed, p) : 0.0;
        if (mode) mode[px] = kWwhTraversal;
      }
    }
  });
}

}  // namespace glintlab
