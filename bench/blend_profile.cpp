// One blend call against the inner law's batch (gated at (4e4, 0.01)), one thread: ns a sample (best
// of 5 calls each, measured back to back) by the wall clock and by the process's CPU time (which a
// loaded machine inflates far less: waiting for a core is not counted), and, under callgrind,
// instruction counts of blend_call and inner_batch (issues 32 and 43; docs/guide/performance.md):
//   build/bench/glintlab_bench_blend_profile roulette 8 1000000          (one footprint area P = 8)
//   build/bench/glintlab_bench_blend_profile roulette 0 1000000          (P per sample over [1, 16])
//   build/bench/glintlab_bench_blend_profile roulette 200:800 1000000    (P per sample over [200, 800])
//   valgrind --tool=callgrind build/bench/glintlab_bench_blend_profile zk16_linear 0 100000
//   callgrind_annotate --inclusive=yes callgrind.out.* | grep -E "blend_call|inner_batch"
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "glintlab/counting/blend.hpp"
#include "glintlab/counting/law.hpp"
using namespace glintlab;
__attribute__((noinline)) static void inner_batch(const CountingLaw& law, std::size_t m, double* out) {
  const double n = 4e4, p = 0.01;
  sample_many(law, {&n, 1}, {&p, 1}, m, 1, out);
}
__attribute__((noinline)) static void blend_call(const BlendedLaw& b, double P, const std::vector<double>& Ps,
                                                 std::size_t m, double* out) {
  const double p = 0.01;
  if (Ps.empty())
    b.sample(1e4, {&P, 1}, {&p, 1}, m, 1, out);
  else
    b.sample(1e4, {Ps.data(), m}, {&p, 1}, m, 1, out);
}
// Log-uniform footprints over [lo, hi) from a fixed-seed hash: as random as numpy's footprints in
// bench_paths.py (a golden-ratio sequence let the branch predictor learn the level pattern, hiding
// mispredictions the random footprints pay).
static std::vector<double> random_footprints(double lo, double hi, std::size_t m) {
  std::vector<double> Ps(m);
  std::uint64_t state = 12345;
  for (std::size_t i = 0; i < m; ++i) {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    Ps[i] = lo * std::exp(std::log(hi / lo) * (static_cast<double>(z >> 11) * 0x1p-53));
  }
  return Ps;
}
static double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr,
                 "usage: %s RULE P SAMPLES (P: one footprint area; 0: P per sample, log-uniform over [1, 16]; "
                 "LO:HI: log-uniform over [LO, HI])\n",
                 argv[0]);
    return 2;
  }
  const std::string rule = argv[1];
  const std::string area = argv[2];
  const std::size_t m = std::strtoul(argv[3], nullptr, 10);
  double P = 0;
  std::vector<double> Ps;
  if (const auto colon = area.find(':'); colon != std::string::npos)
    Ps = random_footprints(std::atof(area.substr(0, colon).c_str()), std::atof(area.substr(colon + 1).c_str()), m);
  else if ((P = std::atof(area.c_str())) == 0)
    Ps = random_footprints(1, 16, m);
  set_num_threads(1);
  std::shared_ptr<const CountingLaw> law(make_law("gated"));
  BlendedLaw b(make_blend(rule), InnerLaw::from_law(law), LevelLadder(4, 1));
  std::vector<double> out(m);
  const double samples = static_cast<double>(m);
  auto now = [] { return std::chrono::steady_clock::now(); };
  double ti = 1e9, tb = 1e9, ci = 1e9, cb = 1e9;
  for (int rep = 0; rep < 5; ++rep) {
    const double c0 = cpu_seconds();
    auto t0 = now();
    inner_batch(*law, m, out.data());
    auto t1 = now();
    const double c1 = cpu_seconds();
    blend_call(b, P, Ps, m, out.data());
    auto t2 = now();
    const double c2 = cpu_seconds();
    ti = std::min(ti, std::chrono::duration<double>(t1 - t0).count());
    tb = std::min(tb, std::chrono::duration<double>(t2 - t1).count());
    ci = std::min(ci, c1 - c0);
    cb = std::min(cb, c2 - c1);
  }
  std::printf("inner %.2f ns, blend %.2f ns, ratio %.1f; cpu: inner %.2f ns, blend %.2f ns, ratio %.1f\n",
              ti / samples * 1e9, tb / samples * 1e9, tb / ti, ci / samples * 1e9, cb / samples * 1e9, cb / ci);
  double s = 0;
  for (double v : out) s += v;
  std::printf("%s P=%s mean %g\n", rule.c_str(), area.c_str(), s / samples);
}
