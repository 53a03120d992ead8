// The gated law's per-pixel path against its batch, and the batch's parts (issue 32; see
// docs/guide/performance.md). One thread, a preallocated output (no page faults in the times):
//   build/bench/glintlab_bench_gated_profile                 wall clock: best of many short calls of
//                                                            each path, back to back (ns a sample;
//                                                            batch: the sampler's sample_range)
//   valgrind --tool=callgrind build/bench/glintlab_bench_gated_profile pixels 200000
//   valgrind --tool=callgrind build/bench/glintlab_bench_gated_profile batch 1e6 0.3 200000
//   callgrind_annotate --inclusive=yes callgrind.out.* | grep -E "pixels_call|batch_call|rows_call"
// The per-pixel (n, p) are drawn from the standard grid (python/glintlab/data/grids/standard.json),
// as bench/bench_paths.py draws them; the batch points are its four.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "glintlab/base/rng.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"

using namespace glintlab;

namespace {
constexpr double kPoints[4][2] = {{16, 0.1}, {1e3, 1e-2}, {1e6, 0.3}, {1e9, 1e-6}};

__attribute__((noinline)) void pixels_call(const CountingLaw& law, const std::vector<double>& n,
                                           const std::vector<double>& p, std::size_t m, double* out) {
  sample_many(law, {n.data(), m}, {p.data(), m}, m, 1, out);
}
__attribute__((noinline)) void batch_call(const CountingLaw& law, double n, double p, std::size_t m, double* out) {
  sample_many(law, {&n, 1}, {&p, 1}, m, 1, out);
}
__attribute__((noinline)) void rows_call(std::size_t m, double* out) {  // the Philox rows alone, 2 uniforms
  constexpr std::size_t kRows = 256;
  for (std::size_t s = 0; s < m; s += kRows)
    detail::philox_uniform_rows(1, kStreamSample, s, std::min(kRows, m - s), 2, out);
}

// The numbers of the flat array `key`: [a, b, ...] in the grid file (a two-key document; no JSON
// library for a bench driver).
std::vector<double> json_numbers(const std::string& text, const std::string& key) {
  std::vector<double> v;
  std::size_t at = text.find('[', text.find(key));
  const std::size_t end = text.find(']', at);
  while (at < end) {
    char* next = nullptr;
    v.push_back(std::strtod(text.c_str() + at + 1, &next));
    at = text.find(',', static_cast<std::size_t>(next - text.c_str()));
    if (at == std::string::npos) break;
  }
  return v;
}

// (n, p) of `m` pixels, uniformly over the standard grid's points.
void grid_pixels(const std::string& path, std::size_t m, std::vector<double>& n, std::vector<double>& p) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "cannot read %s (run from the repository root)\n", path.c_str());
    std::exit(2);
  }
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto gn = json_numbers(text, "\"n\""), gp = json_numbers(text, "\"p\"");
  std::mt19937_64 rng(1);
  std::uniform_int_distribution<std::size_t> pick(0, gn.size() * gp.size() - 1);
  n.resize(m);
  p.resize(m);
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t k = pick(rng);
    n[i] = gn[k / gp.size()];
    p[i] = gp[k % gp.size()];
  }
}

template <class F>
double best_ns(F&& f, std::size_t m, int reps) {
  double best = 1e30;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const auto t1 = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double>(t1 - t0).count());
  }
  return best / static_cast<double>(m) * 1e9;
}
}  // namespace

int main(int argc, char** argv) {
  const std::string grid = "python/glintlab/data/grids/standard.json";
  set_num_threads(1);
  std::unique_ptr<CountingLaw> law(make_law("gated"));
  const std::string mode = argc > 1 ? argv[1] : "wall";
  if (mode == "pixels" && argc == 3) {
    const std::size_t m = std::strtoul(argv[2], nullptr, 10);
    std::vector<double> n, p, out(m);
    grid_pixels(grid, m, n, p);
    pixels_call(*law, n, p, m, out.data());
    return 0;
  }
  if (mode == "batch" && argc == 5) {
    const std::size_t m = std::strtoul(argv[4], nullptr, 10);
    std::vector<double> out(m);
    batch_call(*law, std::atof(argv[2]), std::atof(argv[3]), m, out.data());
    return 0;
  }
  if (mode == "rows" && argc == 3) {
    std::vector<double> out(512);
    rows_call(std::strtoul(argv[2], nullptr, 10), out.data());
    return 0;
  }
  if (mode != "wall" || argc > 3) {
    std::fprintf(stderr, "usage: %s [wall [REPS] | pixels M | batch N P M | rows M]\n", argv[0]);
    return 2;
  }
  // Short calls (65536 samples into a buffer that stays in cache, well under a scheduler slice), the
  // best of many: on a loaded machine the minimum is the uninterrupted time, and the paths alternate,
  // so that each sees the same load. The batch samplers are built once (a 1e7 batch amortizes its
  // table: 1 MiB at (1e6, 0.3)), so the rows compare the per-sample work of each path.
  const int reps = argc == 3 ? std::atoi(argv[2]) : 100;
  constexpr std::size_t m = 1 << 16;
  std::vector<double> n, p, out(m), rows(512);
  grid_pixels(grid, m, n, p);
  std::unique_ptr<detail::BatchSampler> samplers[4];
  for (int i = 0; i < 4; ++i)
    samplers[i] = detail::KernelOf(*law)->batch_sampler(kPoints[i][0], kPoints[i][1], 10'000'000);
  double pix = 1e30, row = 1e30, batch[4] = {1e30, 1e30, 1e30, 1e30};
  for (int r = 0; r < reps; ++r) {
    pix = std::min(pix, best_ns([&] { pixels_call(*law, n, p, m, out.data()); }, m, 1));
    row = std::min(row, best_ns([&] { rows_call(m, rows.data()); }, m, 1));
    for (int i = 0; i < 4; ++i)
      batch[i] = std::min(batch[i], best_ns([&] { samplers[i]->sample_range(1, 0, m, out.data()); }, m, 1));
  }
  double mean = 0;
  for (int i = 0; i < 4; ++i) {
    std::printf("batch (%g, %g): %.3f ns\n", kPoints[i][0], kPoints[i][1], batch[i]);
    mean += batch[i] / 4;
  }
  std::printf("Philox rows (2 uniforms): %.3f ns\n", row);
  std::printf("per-pixel: %.3f ns; batch mean %.3f ns; per-pixel / batch = %.2f\n", pix, mean, pix / mean);
}
