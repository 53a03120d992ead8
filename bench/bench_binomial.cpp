// Benchmark of the exact binomial sampler against std::binomial_distribution (C++ side of
// `make bench`; validation/bench/bench_binomial.py runs it and adds the numpy and Python timings).
//
// For each (n, p) of the four points it times, in nanoseconds per sample:
//   std    std::binomial_distribution<long long> on std::mt19937_64, one thread;
//   gl_1t  glintlab::binomial::Sampler, one thread, one CounterRng::for_index per sample
//          (exactly what one core does inside sample_many);
//   gl_mt  glintlab::sample_many on glintlab's threads (all cores, or $GLINTLAB_NUM_THREADS):
//          what law.sample() does, minus Python.
// Every method writes its draws into the same preallocated, already touched buffer, so all three
// pay for the stores but none for page faults of fresh memory; the buffer is summed after the
// timed region, which both keeps the compiler from dropping the work and gives the sample mean
// and variance (the Python side checks them against n p and n p q).
// The reported time is the best (minimum) of --repeats timed runs: timing noise on a shared
// machine only ever adds time, so the minimum is the most reproducible estimate of the cost. A
// multi-threaded run that visibly did not get its cores (another process held one) is repeated, up
// to kRetries times per repeat; every run, starved or not, is listed in the output.
//
// Usage: glintlab_bench_binomial [--size N] [--repeats R] [--seed S]
// Output: one JSON document on stdout: {"size", "repeats", "seed", "threads", "statistic",
// "points": [{"n", "p", "std": {...}, "gl_1t": {...}, "gl_mt": {...}}, ...]}, each method with
// ns_per_sample (best), median_ns_per_sample, cores, mean, var (sample variance) and runs
// ([ns per sample, cores] of each timed run).
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iterator>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "glintlab/base/rng.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/binomial.hpp"

namespace {

struct Point {
  double n, p;
};
// The points. In binomial::Sampler: inversion (n p = 1.6); BTRD just past its threshold
// (n p = 10, the inversion branch takes n p < 10); BTRD with a large mean (3e5); BTRD with a huge
// n and a moderate mean (1e3).
constexpr Point kPoints[] = {{16, 0.1}, {1e3, 1e-2}, {1e6, 0.3}, {1e9, 1e-6}};

// Extra attempts of a multi-threaded run that got less than kStarved of its threads' CPU time.
constexpr int kRetries = 3;
constexpr double kStarved = 0.85;
// Below this wall time the process CPU time is too coarse (other threads' time is accounted at
// ticks and context switches) to tell a starved run from a normal one.
constexpr double kMinJudgedNs = 50e6;

struct Options {
  std::size_t size = 10'000'000;
  int repeats = 3;
  std::uint64_t seed = 1;
};

[[noreturn]] void usage(const char* msg) {
  std::fprintf(stderr,
               "glintlab_bench_binomial: %s\nusage: glintlab_bench_binomial [--size N] "
               "[--repeats R] [--seed S]\n",
               msg);
  std::exit(2);
}

// A count >= 1, read as a double so that "1e7" works (counts never need more than 53 bits).
std::uint64_t parse_count(const char* text, const char* what) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v >= 1) || v > 1e15 || v != std::floor(v))
    usage((std::string("bad ") + what + " " + text).c_str());
  return static_cast<std::uint64_t>(v);
}

// A seed: any 64-bit integer, as glintlab's seeds are.
std::uint64_t parse_seed(const char* text) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(text, &end, 10);
  if (end == text || *end != '\0' || errno == ERANGE || text[0] == '-')
    usage((std::string("bad --seed ") + text).c_str());
  return v;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) usage(("missing value after " + a).c_str());
    const char* value = argv[++i];
    if (a == "--size")
      o.size = parse_count(value, "--size");
    else if (a == "--repeats")
      o.repeats = static_cast<int>(parse_count(value, "--repeats"));
    else if (a == "--seed")
      o.seed = parse_seed(value);
    else
      usage(("unknown argument " + a).c_str());
  }
  return o;
}

// One method's result at one point.
struct Timing {
  double best_ns = 0;                           // per sample, minimum over repeats
  double median_ns = 0;                         // per sample, for judging the spread
  double cores = 0;                             // process CPU time / wall time of the best run: below the thread count
                                                // when other processes took cores away from a multi-threaded run
  double mean = 0;                              // sample mean of the last run
  double var = 0;                               // sample variance of the last run
  std::vector<std::pair<double, double>> runs;  // (ns per sample, cores) of every timed run
};

// Times fill(out) `repeats` times after one untimed warm-up call (which also starts OpenMP's
// threads and faults the buffer in, if that has not happened yet). `threads`: the threads that
// fill uses, for judging whether a run got them.
template <class Fill>
Timing time_method(std::vector<double>& out, int repeats, int threads, Fill fill) {
  using clock = std::chrono::steady_clock;
  fill(out);
  Timing t;
  auto& runs = t.runs;
  for (int r = 0; r < repeats; ++r) {
    for (int attempt = 0; attempt <= (threads > 1 ? kRetries : 0); ++attempt) {
      const std::clock_t c0 = std::clock();  // CPU time of all threads of the process (Linux)
      const auto t0 = clock::now();
      fill(out);
      const auto t1 = clock::now();
      const std::clock_t c1 = std::clock();
      const double wall_ns = std::chrono::duration<double, std::nano>(t1 - t0).count();
      const double cores = 1e9 * static_cast<double>(c1 - c0) / CLOCKS_PER_SEC / wall_ns;
      runs.emplace_back(wall_ns / static_cast<double>(out.size()), cores);
      if (cores >= kStarved * threads || wall_ns < kMinJudgedNs) break;
    }
  }
  auto sorted = runs;
  std::sort(sorted.begin(), sorted.end());
  t.best_ns = sorted.front().first;
  t.cores = sorted.front().second;
  t.median_ns = sorted[sorted.size() / 2].first;
  // Draws are integers and their total stays far below 2^53 at these points, so the sum is exact.
  double sum = 0;
  for (double x : out) sum += x;
  t.mean = sum / static_cast<double>(out.size());
  double ss = 0;  // second pass about the mean: no cancellation
  for (double x : out) ss += (x - t.mean) * (x - t.mean);
  t.var = ss / static_cast<double>(out.size() > 1 ? out.size() - 1 : 1);
  return t;
}

// Shortest text that reads back as the same double (so p prints as 0.1, not 0.10000000000000001).
std::string shortest(double x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

void print_timing(const char* name, const Timing& t, bool last) {
  std::printf(
      "      \"%s\": {\"ns_per_sample\": %.6g, \"median_ns_per_sample\": %.6g, "
      "\"cores\": %.3g, \"mean\": %s, \"var\": %.17g, \"runs\": [",
      name, t.best_ns, t.median_ns, t.cores, shortest(t.mean).c_str(), t.var);
  for (std::size_t i = 0; i < t.runs.size(); ++i)
    std::printf("%s[%.6g, %.3g]", i ? ", " : "", t.runs[i].first, t.runs[i].second);
  std::printf("]}%s\n", last ? "" : ",");
}

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parse(argc, argv);
  std::vector<double> out(opt.size);
  const auto law = glintlab::make_law("binomial");

  std::printf(
      "{\n  \"size\": %zu,\n  \"repeats\": %d,\n  \"seed\": %llu,\n  \"threads\": %d,\n"
      "  \"statistic\": \"min over repeats\",\n  \"points\": [\n",
      opt.size, opt.repeats, static_cast<unsigned long long>(opt.seed), glintlab::num_threads());

  for (std::size_t k = 0; k < std::size(kPoints); ++k) {
    const double n = kPoints[k].n, p = kPoints[k].p;

    // (a) The standard library's sampler, reseeded per call so that every run draws the same
    // numbers.
    const Timing std_t = time_method(out, opt.repeats, 1, [&](std::vector<double>& o) {
      std::mt19937_64 engine(opt.seed);
      std::binomial_distribution<long long> dist(static_cast<long long>(n), p);
      for (double& x : o) x = static_cast<double>(dist(engine));
    });

    // (b) One core's share of sample_many, written out: setup once, one counter RNG per sample.
    const Timing gl1_t = time_method(out, opt.repeats, 1, [&](std::vector<double>& o) {
      const glintlab::binomial::Sampler sampler(n, p, /*tabulate=*/true);  // as sample_range does for a batch
      for (std::size_t i = 0; i < o.size(); ++i) {
        auto rng = glintlab::CounterRng::for_index(opt.seed, i, glintlab::kStreamSample);
        o[i] = sampler(rng);
      }
    });

    // (c) The multi-threaded driver that the Python binding calls.
    const Timing glmt_t = time_method(out, opt.repeats, glintlab::num_threads(), [&](std::vector<double>& o) {
      glintlab::sample_many(*law, glintlab::ParamArray{&n, 1}, glintlab::ParamArray{&p, 1}, o.size(), opt.seed,
                            o.data());
    });

    std::printf("    {\n      \"n\": %s,\n      \"p\": %s,\n", shortest(n).c_str(), shortest(p).c_str());
    print_timing("std", std_t, false);
    print_timing("gl_1t", gl1_t, false);
    print_timing("gl_mt", glmt_t, true);
    std::printf("    }%s\n", k + 1 < std::size(kPoints) ? "," : "");
    std::fflush(stdout);
  }
  std::printf("  ]\n}\n");
  return 0;
}
