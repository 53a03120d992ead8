#include "glintlab/counting/law.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include "base/parallel.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/detail/law_kernel.hpp"

namespace glintlab {

namespace {

// Laws' batches: below this many items (about 0.3 ms of draws at 20 ns each) a batch runs on the
// calling thread. Waking a worker costs tens of microseconds on an idle machine and can cost
// milliseconds on a loaded one (a short sample() of 1e4 draws took 7-16 ms with two threads against
// 0.05-0.08 ms with one, under a load of 4-8 on 2 cores): a short call must not pay it.
constexpr std::size_t kParallelThreshold = 16384;

template <class Body>
void parallel_chunks(std::size_t count, Body body) {
  detail::parallel_chunks(count, 4096, kParallelThreshold, std::move(body));
}

// The two per-pixel scans of the drivers, compiled for AVX-512 and AVX2 too and picked at load time
// (GCC's target_clones): for the baseline ISA (SSE2) GCC leaves them scalar, and with a compare and
// a branch per element they cost 4-5 ns of a per-pixel draw's ~25 (perf). Integer results: the same
// on every clone.
// Whether some (n[i], p[i]), i in [a, b), is outside accepts()'s domain.
__attribute__((target_clones("avx512f", "avx2", "default"))) bool any_outside_domain(const double* n, const double* p,
                                                                                     std::size_t a, std::size_t b,
                                                                                     double max_n) {
  int bad = 0;
#pragma omp simd reduction(| : bad)
  for (std::size_t i = a; i < b; ++i) bad |= !((n[i] >= 0.0) & (n[i] <= max_n) & (p[i] >= 0.0) & (p[i] <= 1.0));
  return bad != 0;
}
// #{j in (a, b) : n[j] == n[j - 1] and p[j] == p[j - 1]}.
__attribute__((target_clones("avx512f", "avx2", "default"))) std::size_t count_equal_pairs(const double* n,
                                                                                           const double* p,
                                                                                           std::size_t a,
                                                                                           std::size_t b) {
  std::size_t equal = 0;
#pragma omp simd reduction(+ : equal)
  for (std::size_t j = a + 1; j < b; ++j) equal += (n[j] == n[j - 1]) & (p[j] == p[j - 1]);
  return equal;
}

// The per-pixel driver's one pass over a block of two arrays: whether some (n[i], p[i]), i in [a, b),
// is outside accepts()'s domain (any_outside_domain), and, into `equal`, count_equal_pairs: the
// block's parameters are read once, then stay in L1 for the draws.
__attribute__((target_clones("avx512f", "avx2", "default"))) bool scan_pixel_block(const double* n, const double* p,
                                                                                   std::size_t a, std::size_t b,
                                                                                   double max_n, std::size_t& equal) {
  int bad = !((n[a] >= 0.0) & (n[a] <= max_n) & (p[a] >= 0.0) & (p[a] <= 1.0));
  std::size_t eq = 0;
#pragma omp simd reduction(| : bad) reduction(+ : eq)
  for (std::size_t j = a + 1; j < b; ++j) {
    bad |= !((n[j] >= 0.0) & (n[j] <= max_n) & (p[j] >= 0.0) & (p[j] <= 1.0));
    eq += (n[j] == n[j - 1]) & (p[j] == p[j - 1]);
  }
  equal = eq;
  return bad != 0;
}

// The first i in [a, b) that accepts() refuses, or b.
std::size_t first_refused(const CountingLaw& law, ParamArray n, ParamArray p, std::size_t a, std::size_t b) {
  for (std::size_t i = a; i < b; ++i)
    if (!law.accepts(n[i], p[i])) return i;
  return b;
}

// Records i as a refused element: the lowest index wins, whatever the threads' order.
void record_refused(std::atomic<std::size_t>& first_bad, std::size_t i) {
  std::size_t seen = first_bad.load();
  while (i < seen && !first_bad.compare_exchange_weak(seen, i)) {}
}

void validate_all(const CountingLaw& law, ParamArray n, ParamArray p, std::size_t count) {
  check_length("", "n", n.size, count);
  check_length("", "p", p.size, count);
  // The check is a virtual call per element (2 ns of a per-pixel draw's ~30): split across the
  // threads like the draws, then the first bad element (lowest index) is named, as a serial scan would.
  const std::size_t m = std::max(n.size, p.size);
  std::atomic<std::size_t> first_bad{m};
  const double max_n = law.max_n();
  parallel_chunks(m, [&](std::size_t i0, std::size_t i1) {
    if (n.size > 1 && p.size > 1) {
      // accepts() as one vectorized pass (bitwise logic, no branch); the element scan below only
      // for a chunk that holds a bad element.
      if (!any_outside_domain(n.data, p.data, i0, i1, max_n)) return;
    }
    if (const std::size_t i = first_refused(law, n, p, i0, i1); i < i1) record_refused(first_bad, i);
  });
  if (const std::size_t i = first_bad.load(); i < m) law.validate(n[i], p[i], i, m > 1);
}

// #{j in (a, b) : (n[j], p[j]) == (n[j - 1], p[j - 1])}, branch-free (vectorized for arrays).
std::size_t count_equal_neighbours(ParamArray n, ParamArray p, std::size_t a, std::size_t b) {
  std::size_t equal = 0;
  if (n.size > 1 && p.size > 1) {
    equal = count_equal_pairs(n.data, p.data, a, b);
  } else {
    for (std::size_t j = a + 1; j < b; ++j)  // branch-free: & of two 0/1 integers
      equal += static_cast<std::size_t>(n[j] == n[j - 1]) & static_cast<std::size_t>(p[j] == p[j - 1]);
  }
  return equal;
}

}  // namespace

namespace detail {

std::unique_ptr<FixedEvaluator> LawKernel::fixed_evaluator(double n, double p, std::size_t) const {
  return make_fixed_evaluator([&law = law(), n, p](const double* u, std::size_t rows, double* out) {
    const auto k = static_cast<std::size_t>(law.n_uniforms());
    for (std::size_t r = 0; r < rows; ++r) out[r] = law.evaluate(n, p, u + r * k);
  });
}

void LawKernel::evaluate_pixels(const double* n, const double* p, const double* u, std::size_t count,
                                double* out) const {
  const auto k = static_cast<std::size_t>(law().n_uniforms());
  for (std::size_t i = 0; i < count; ++i) out[i] = law().evaluate(n[i], p[i], u + i * k);
}

void LawKernel::sample_range(double n, double p, std::uint64_t seed, std::size_t i0, std::size_t i1,
                             double* out) const {
  // The uniforms of fill_uniforms (the vectorized Philox), a block of rows at a time.
  const int k = law().n_uniforms();
  const std::size_t kk = static_cast<std::size_t>(k);
  constexpr std::size_t kRows = 256, kStackUniforms = 4;  // as sample_pixels: no allocation, no zero-fill
  alignas(64) double stack_rows[kRows * kStackUniforms];
  std::unique_ptr<double[]> heap_rows(kk > kStackUniforms ? new double[kRows * kk] : nullptr);
  double* u = heap_rows ? heap_rows.get() : stack_rows;
  for (std::size_t b0 = i0; b0 < i1; b0 += kRows) {
    const std::size_t rows = std::min(kRows, i1 - b0);
    if (k > 0) philox_uniform_rows(seed, kStreamSample, b0, rows, k, u);
    for (std::size_t r = 0; r < rows; ++r) out[b0 - i0 + r] = law().evaluate(n, p, u + r * kk);
  }
}

void LawKernel::sample_pixels(const double* n, const double* p, std::uint64_t seed, std::size_t start,
                              std::size_t count, double* out) const {
  const std::size_t k = static_cast<std::size_t>(law().n_uniforms());
  if (!samples_by_evaluate() || k == 0) {
    for (std::size_t r = 0; r < count; ++r) sample_range(n[r], p[r], seed, start + r, start + r + 1, out + r);
    return;
  }
  // The rows on the stack for up to 4 uniforms (every law of the registry): no allocation and no
  // zero-fill per call; Philox writes every element that evaluate_pixels reads.
  constexpr std::size_t kRows = 256, kStackUniforms = 4;
  alignas(64) double stack_rows[kRows * kStackUniforms];
  std::unique_ptr<double[]> heap_rows(k > kStackUniforms ? new double[kRows * k] : nullptr);
  double* u = heap_rows ? heap_rows.get() : stack_rows;
  for (std::size_t b = 0; b < count; b += kRows) {
    const std::size_t rows = std::min(kRows, count - b);
    philox_uniform_rows(seed, kStreamSample, start + b, rows, static_cast<int>(k), u);
    evaluate_pixels(n + b, p + b, u, rows, out + b);
  }
}

std::unique_ptr<BatchSampler> LawKernel::batch_sampler(double n, double p, std::size_t count) const {
  const int k = law().n_uniforms();
  if (!samples_by_evaluate() || k < 1 || k > 4) return nullptr;
  // The fixed evaluator on blocks of the batch's rows: the same values as sample_range's evaluate().
  return make_block_batch_sampler(
      k, [fixed = std::shared_ptr<const FixedEvaluator>(fixed_evaluator(n, p, count))](
             const double* u, std::size_t rows, double* out) { fixed->evaluate(u, rows, out); });
}

}  // namespace detail

double CountingLaw::evaluate_f32(double, double, const double*) const {
  throw_invalid(name(), "precision", "'float32'", "'float64' (this law is defined in float64 only)");
}

Precision precision_from_name(const std::string& name) {
  static constexpr std::pair<std::string_view, Precision> kPrecisions[] = {{"float64", Precision::kFloat64},
                                                                           {"float32", Precision::kFloat32}};
  return parse_enum("", "precision", name, kPrecisions);
}

std::string precision_name(Precision precision) { return precision == Precision::kFloat32 ? "float32" : "float64"; }

namespace {
void require_precision(const CountingLaw& law, Precision precision) {
  if (!law.supports(precision))
    throw_invalid(law.name(), "precision", "'" + precision_name(precision) + "'",
                  "'float64' (this law is defined in float64 only)");
}

// float32 sampling: evaluate_f32 on the batch uniforms, a block of rows at a time.
void sample_range_f32(const CountingLaw& law, double n, double p, std::uint64_t seed, std::size_t i0, std::size_t i1,
                      double* out) {
  const std::size_t kk = static_cast<std::size_t>(law.n_uniforms());
  constexpr std::size_t kRows = 256;
  std::vector<double> u(kRows * std::max<std::size_t>(kk, 1));
  for (std::size_t b0 = i0; b0 < i1; b0 += kRows) {
    const std::size_t rows = std::min(kRows, i1 - b0);
    if (kk > 0) detail::philox_uniform_rows(seed, kStreamSample, b0, rows, static_cast<int>(kk), u.data());
    for (std::size_t r = 0; r < rows; ++r) out[b0 - i0 + r] = law.evaluate_f32(n, p, u.data() + r * kk);
  }
}
}  // namespace

Distribution CountingLaw::pmf(double, double, std::size_t) const {
  throw not_implemented("law '" + name() + "' has no exact distribution; estimate one from samples instead");
}

void CountingLaw::validate(double n, double p, std::size_t index, bool is_array) const {
  if (accepts(n, p)) return;
  const std::string where = name();
  check_n(where, n, indexed_name("n", index, is_array));
  check_p(where, p, indexed_name("p", index, is_array));
  if (n > max_n_)
    throw_invalid(where, indexed_name("n", index, is_array), n,
                  "n <= " + format_value(max_n_) + ", the law's numeric domain (" + domain_note_ + ")");
  throw_invalid_message(where + ": (n, p) = (" + format_value(n) + ", " + format_value(p) +
                        ") is outside the law's domain");
}

void CountingLaw::apply_traits(const LawTraits& traits) {
  max_n_ = traits.domain.max_n;
  domain_note_ = traits.domain.note;
  binning_ = traits.binning();
}

Registry<LawInfo>& law_registry() {
  static Registry<LawInfo> laws("law");
  return laws;
}

bool register_law(LawInfo info) { return law_registry().add(std::move(info)); }

std::unique_ptr<CountingLaw> make_law(const std::string& name, const LawParams& params) {
  std::unique_ptr<CountingLaw> law = law_registry().make(name, params);
  law->apply_traits(law_registry().find(name).traits);  // the domain is enforced by accepts() at every entry point
  return law;
}

std::vector<LawInfo> registered_laws() { return law_registry().all(); }

LawTraits law_traits(const std::string& name) { return law_registry().find(name).traits; }

std::string law_output_name(LawOutput output) { return output == LawOutput::kInteger ? "integer" : "real"; }

std::string support_bound_name(SupportBound bound) {
  switch (bound) {
    case SupportBound::kBoundedByN: return "bounded_by_n";
    case SupportBound::kNPlusOne: return "n_plus_one";
    case SupportBound::kUnbounded: break;
  }
  return "unbounded";
}

double LawTraits::max_count(double n) const {
  switch (support) {
    case SupportBound::kBoundedByN: return std::ceil(n);
    case SupportBound::kNPlusOne: return std::ceil(n) + 1;
    case SupportBound::kUnbounded: break;
  }
  return std::numeric_limits<double>::infinity();
}

double ParamReader::number(const std::string& key, double fallback) {
  known_.push_back(key);
  auto it = params_.find(key);
  if (it == params_.end()) return fallback;
  if (const double* v = std::get_if<double>(&it->second)) {
    if (!std::isfinite(*v)) throw_invalid("law '" + law_ + "'", key, *v, "a finite number");
    return *v;
  }
  throw_invalid("law '" + law_ + "'", key, "'" + std::get<std::string>(it->second) + "'", "a number");
}

std::string ParamReader::text(const std::string& key, const std::string& fallback,
                              const std::vector<std::string>& allowed) {
  known_.push_back(key);
  auto it = params_.find(key);
  if (it == params_.end()) return fallback;
  std::string options;
  for (const auto& a : allowed) options += (options.empty() ? "'" : ", '") + a + "'";
  const std::string* v = std::get_if<std::string>(&it->second);
  if (!v) throw_invalid("law '" + law_ + "'", key, std::get<double>(it->second), "one of " + options);
  if (std::find(allowed.begin(), allowed.end(), *v) == allowed.end())
    throw_invalid("law '" + law_ + "'", key, "'" + *v + "'", "one of " + options);
  return *v;
}

void ParamReader::finish() const {
  for (const auto& [key, value] : params_) {
    if (std::find(known_.begin(), known_.end(), key) == known_.end()) {
      std::string options;
      for (const auto& k : known_) options += (options.empty() ? "" : ", ") + k;
      throw_invalid_message("law '" + law_ + "': unknown parameter '" + key + "'; expected " +
                            (options.empty() ? "no parameters" : "one of: " + options));
    }
  }
}

void sample_many(const CountingLaw& law, ParamArray n, ParamArray p, std::size_t count, std::uint64_t seed, double* out,
                 Precision precision) {
  require_precision(law, precision);
  // Two arrays (a renderer's pixels): the validation is fused into the draw pass below (one read of
  // each block of (n, p), which then stays in cache for the draws); otherwise everything first.
  const bool fused = n.size > 1 && p.size > 1;
  if (fused) {
    check_length("", "n", n.size, count);
    check_length("", "p", p.size, count);
  } else {
    validate_all(law, n, p, count);
  }
  const detail::KernelOf kernel(law);
  const auto range = [&](double nn, double pp, std::size_t i0, std::size_t i1, double* o) {
    if (precision == Precision::kFloat32)
      sample_range_f32(law, nn, pp, seed, i0, i1, o);
    else
      kernel->sample_range(nn, pp, seed, i0, i1, o);
  };
  if (n.size == 1 && p.size == 1) {
    if (precision == Precision::kFloat64 && count >= kTabulateMinBatch) {
      if (const auto batch = kernel->batch_sampler(n[0], p[0], count)) {
        parallel_chunks(count, [&](std::size_t i0, std::size_t i1) { batch->sample_range(seed, i0, i1, out + i0); });
        return;
      }
    }
    parallel_chunks(count, [&](std::size_t i0, std::size_t i1) { range(n[0], p[0], i0, i1, out + i0); });
    return;
  }
  // Runs of equal (n, p) share one sampler setup (results are keyed by index, so unchanged);
  // short runs are gathered into blocks of pixels for the law's sample_pixels (its vector
  // per-pixel path: evaluate_pixels on one block of uniforms, or prefetched Philox rows).
  constexpr std::size_t kShortRun = 16, kRows = 256, kBlock = 8 * kRows;
  const std::size_t k = static_cast<std::size_t>(law.n_uniforms());
  const bool n_array = n.size > 1 || count == 1, p_array = p.size > 1 || count == 1;
  const double max_n = law.max_n();
  // The lowest refused index of the fused validation (count: none). A block with a refused element
  // is not drawn, and its chunk stops: the other chunks still record theirs, so the lowest index
  // overall is the one named, as a serial scan would name it. out is then partly written.
  std::atomic<std::size_t> first_bad{count};
  parallel_chunks(count, [&](std::size_t i0, std::size_t i1) {
    std::vector<double> u(precision == Precision::kFloat32 ? kRows * std::max<std::size_t>(k, 1) : 0);
    alignas(64) double nb[kRows], pb[kRows];  // a scalar n or p broadcast into a block
    // Pixels [a, b) by the per-pixel path; the arrays are passed in place.
    const auto pixels = [&](std::size_t a, std::size_t b) {
      if (a == b) return;
      if (precision == Precision::kFloat64 && n_array && p_array) {
        kernel->sample_pixels(n.data + a, p.data + a, seed, a, b - a, out + a);
        return;
      }
      for (std::size_t s = a; s < b; s += kRows) {
        const std::size_t rows = std::min(kRows, b - s);
        if (precision == Precision::kFloat32) {
          if (k > 0) detail::philox_uniform_rows(seed, kStreamSample, s, rows, static_cast<int>(k), u.data());
          for (std::size_t r = 0; r < rows; ++r) out[s + r] = law.evaluate_f32(n[s + r], p[s + r], u.data() + r * k);
          continue;
        }
        if (!n_array) std::fill(nb, nb + rows, n.data[0]);
        if (!p_array) std::fill(pb, pb + rows, p.data[0]);
        kernel->sample_pixels(n_array ? n.data + s : nb, p_array ? p.data + s : pb, seed, s, rows, out + s);
      }
    };
    for (std::size_t i = i0; i < i1;) {
      const std::size_t b1 = std::min(i1, i + kBlock);
      // A run of kShortRun equal pixels needs kShortRun - 1 equal neighbours: most blocks of a
      // renderer's pixels have none, and this branch-free count settles them (a run crossing the
      // block's end may then be drawn pixel by pixel: the same values, at the per-pixel cost).
      std::size_t equal_neighbours = 0;
      if (fused) {
        if (first_bad.load(std::memory_order_relaxed) < i) return;  // an earlier pixel is refused
        if (scan_pixel_block(n.data, p.data, i, b1, max_n, equal_neighbours)) {
          if (const std::size_t bad = first_refused(law, n, p, i, b1); bad < b1) {
            record_refused(first_bad, bad);
            return;
          }
        }
      } else {
        equal_neighbours = count_equal_neighbours(n, p, i, b1);
      }
      if (equal_neighbours + 1 < kShortRun) {
        pixels(i, b1);
        i = b1;
        continue;
      }
      // Pixels past b1 equal to a pixel of the block are drawn with it: they are valid with it.
      std::size_t pending = i;  // short-run pixels [pending, i) not drawn yet
      while (i < b1) {
        std::size_t j = i + 1;
        while (j < i1 && n[j] == n[i] && p[j] == p[i]) ++j;
        if (j - i >= kShortRun) {
          pixels(pending, i);
          range(n[i], p[i], i, j, out + i);
          pending = j;
        }
        i = j;
      }
      pixels(pending, i);
    }
  });
  if (const std::size_t i = first_bad.load(); i < count) law.validate(n[i], p[i], i, true);
}

void evaluate_many(const CountingLaw& law, ParamArray n, ParamArray p, const double* u, std::size_t count, double* out,
                   Precision precision) {
  require_precision(law, precision);
  validate_all(law, n, p, count);
  const std::size_t k = static_cast<std::size_t>(law.n_uniforms());
  for (std::size_t i = 0; i < count * k; ++i)
    if (!(u[i] >= 0.0 && u[i] <= 1.0))
      throw_invalid(law.name(), "u[" + std::to_string(i / k) + ", " + std::to_string(i % k) + "]", u[i],
                    "a uniform number in [0, 1]");
  parallel_chunks(count, [&](std::size_t i0, std::size_t i1) {
    if (precision == Precision::kFloat32) {
      for (std::size_t i = i0; i < i1; ++i) out[i] = law.evaluate_f32(n[i], p[i], u + i * k);
    } else {
      for (std::size_t i = i0; i < i1; ++i) out[i] = law.evaluate(n[i], p[i], u + i * k);
    }
  });
}

void fill_uniforms(std::uint64_t seed, std::uint16_t stream, std::size_t start, std::size_t count, int k, double* out) {
  if (k < 0) throw_invalid("uniforms", "n_uniforms", k, "an integer >= 0");
  if (k == 0) return;
  const std::size_t kk = static_cast<std::size_t>(k);
  parallel_chunks(count, [&](std::size_t i0, std::size_t i1) {
    detail::philox_uniform_rows(seed, stream, start + i0, i1 - i0, k, out + i0 * kk);
  });
}

}  // namespace glintlab
