// One blend call against the inner law's batch (gated at (4e4, 0.01)), one thread: wall-clock ns a
// sample (best of 5 calls each, measured back to back) and, under callgrind, instruction counts of
// blend_call and inner_batch (issue 32; docs/guide/performance.md):
//   build/bench/glintlab_bench_blend_profile roulette 8 1000000          (P = 0: P per sample)
//   valgrind --tool=callgrind build/bench/glintlab_bench_blend_profile zk16_linear 0 100000
//   callgrind_annotate --inclusive=yes callgrind.out.* | grep -E "blend_call|inner_batch"
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>
#include "glintlab/blend.hpp"
#include "glintlab/law.hpp"
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
int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s RULE P SAMPLES (P = 0: random log-uniform footprints over [1, 16])\n", argv[0]);
    return 2;
  }
  const std::string rule = argv[1];
  const double P = std::atof(argv[2]);  // 0: P per sample
  const std::size_t m = std::strtoul(argv[3], nullptr, 10);
  set_num_threads(1);
  std::shared_ptr<const CountingLaw> law(make_law("gated"));
  BlendedLaw b(make_blend(rule), InnerLaw::from_law(law), LevelLadder(4, 1));
  std::vector<double> out(m), Ps;
  const double samples = static_cast<double>(m);
  if (P == 0) {  // log P uniform over [0, log 16) (two levels), from a fixed-seed hash: as random as
    // numpy's footprints in bench_paths.py (a golden-ratio sequence let the branch predictor learn the
    // level pattern, hiding mispredictions the random footprints pay)
    Ps.resize(m);
    std::uint64_t state = 12345;
    for (std::size_t i = 0; i < m; ++i) {
      std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
      z ^= z >> 31;
      Ps[i] = std::exp(std::log(16.0) * (static_cast<double>(z >> 11) * 0x1p-53));
    }
  }
  auto now = [] { return std::chrono::steady_clock::now(); };
  double ti = 1e9, tb = 1e9;
  for (int rep = 0; rep < 5; ++rep) {
    auto t0 = now();
    inner_batch(*law, m, out.data());
    auto t1 = now();
    blend_call(b, P, Ps, m, out.data());
    auto t2 = now();
    ti = std::min(ti, std::chrono::duration<double>(t1 - t0).count());
    tb = std::min(tb, std::chrono::duration<double>(t2 - t1).count());
  }
  std::printf("inner %.2f ns, blend %.2f ns, ratio %.1f\n", ti / samples * 1e9, tb / samples * 1e9, tb / ti);
  double s = 0;
  for (double v : out) s += v;
  std::printf("%s P=%g mean %g\n", rule.c_str(), P, s / samples);
}
