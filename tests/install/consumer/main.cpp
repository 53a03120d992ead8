// Uses an installed glintlab as a renderer would: lists the registered laws, makes two of them
// (their object files are only kept by the whole-archive link glintlab::core carries) and samples.
#include <cstdio>
#include <cstring>
#include <exception>
#include <vector>

#include "glintlab/counting/law.hpp"
#include "glintlab/plugin.h"  // installed too (plugin authors include only it)

int main() {
  try {
    const auto laws = glintlab::registered_laws();
    std::printf("glintlab %s (package %s, plugin ABI %d): %zu registered laws:", GLINTLAB_VERSION,
                CONSUMER_PACKAGE_VERSION, GLINTLAB_PLUGIN_ABI_VERSION, laws.size());
    for (const auto& info : laws) std::printf(" %s", info.name.c_str());
    std::printf("\n");
    if (std::strcmp(GLINTLAB_VERSION, CONSUMER_PACKAGE_VERSION) != 0) {
      std::fprintf(stderr, "FAIL: library version %s != package version %s\n", GLINTLAB_VERSION,
                   CONSUMER_PACKAGE_VERSION);
      return 1;
    }
    const double n = 40.0, p = 0.3;
    for (const char* name : {"gated", "binomial"}) {
      const auto law = glintlab::make_law(name);
      std::vector<double> k(16);
      glintlab::sample_many(*law, {&n, 1}, {&p, 1}, k.size(), 12345, k.data());
      std::printf("%s:", name);
      for (double v : k) {
        std::printf(" %g", v);
        if (!(v >= 0.0 && v <= n)) {
          std::fprintf(stderr, "\nFAIL: %s sample %g outside [0, %g]\n", name, v, n);
          return 1;
        }
      }
      std::printf("\n");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "FAIL: %s\n", e.what());
    return 1;
  }
  std::printf("consumer: OK\n");
  return 0;
}
