// Loader of plugin laws (glintlab/plugin.h): dlopen, validation of the table, and a CountingLaw
// adapter around the plugin's function pointers.
#include "glintlab/validation/plugin.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/detail/law_kernel.hpp"
#include "glintlab/plugin.h"

namespace glintlab {
namespace {

constexpr int kMaxLaws = 1024;  // a sanity bound on *count (garbage would be larger)
constexpr std::size_t kMaxNameLength = 64;
constexpr long long kFirstCapacity = 4096;  // pmf buffer of the first call; doubled on request

// One validated table entry, copied out of the library (the strings) or pointing into it (code).
struct PluginEntry {
  std::string name, summary, binning, path;
  int n_uniforms = 0;
  double (*evaluate)(double, double, const double*) = nullptr;
  long long (*pmf)(double, double, double*, long long, long long*, int*) = nullptr;
};

// A law like the built-in ones (detail::KernelLaw): its eval is the plugin's function, which the batch
// and per-pixel paths call directly on rows of given uniforms, without a virtual call per row.
class PluginLaw final : public detail::KernelLaw<PluginLaw> {
 public:
  explicit PluginLaw(std::shared_ptr<const PluginEntry> entry) : e_(std::move(entry)) {}

  std::string name() const override { return e_->name; }
  int n_uniforms() const override { return e_->n_uniforms; }
  // float64 only (the plugin ABI's function of doubles).
  double eval(double n, double p, const double* u) const { return e_->evaluate(n, p, u); }

  bool has_pmf() const override { return e_->pmf != nullptr; }

  Distribution pmf(double n, double p, std::size_t max_support) const override {
    if (!e_->pmf) return CountingLaw::pmf(n, p, max_support);  // throws not_implemented
    const std::string at = "(n, p) = (" + format_value(n) + ", " + format_value(p) + ")";
    const auto limit = static_cast<long long>(std::min<std::size_t>(max_support, 1ULL << 40));
    long long capacity = std::min(kFirstCapacity, std::max(limit, 1LL));
    std::vector<double> probs;
    long long first = 0, len = 0;
    int trimmed = 0;
    for (;;) {
      probs.assign(static_cast<std::size_t>(capacity), 0.0);
      first = 0;
      trimmed = 0;
      len = e_->pmf(n, p, probs.data(), capacity, &first, &trimmed);
      if (len != GLINTLAB_PMF_CAPACITY) break;
      if (capacity >= limit)
        glintlab::throw_invalid_message(e_->name + ".pmf: the distribution at " + at + " needs more than " +
                                        std::to_string(max_support) + " points (max_support)");
      capacity = std::min(2 * capacity, limit);
    }
    if (len == GLINTLAB_PMF_NONE)
      throw not_implemented("law '" + e_->name + "' (plugin " + e_->path + ") has no exact distribution at " + at +
                            "; estimate one from samples instead");
    const std::string bad = "plugin law '" + e_->name + "': pmf at " + at;
    if (len < 1 || len > capacity)
      throw std::runtime_error(bad + " returned length " + std::to_string(len) + "; expected 1 to " +
                               std::to_string(capacity) + ", -1 (more room) or -2 (no exact law)");
    if (trimmed < 0 || trimmed > (GLINTLAB_TRIMMED_BELOW | GLINTLAB_TRIMMED_ABOVE))
      throw std::runtime_error(bad + " set *trimmed = " + std::to_string(trimmed) + "; expected bits 1 and 2 only");
    // Integer support first .. first + len - 1 must be exact in double.
    if (std::abs(static_cast<double>(first)) > 0x1p52)
      throw std::runtime_error(bad + " returned first_k = " + std::to_string(first) + "; expected |first_k| < 2^52");
    probs.resize(static_cast<std::size_t>(len));
    double sum = 0.0, c = 0.0;  // compensated: supports reach millions of points
    for (std::size_t i = 0; i < probs.size(); ++i) {
      if (!(probs[i] >= 0.0) || !std::isfinite(probs[i]))
        throw std::runtime_error(bad + ": probs[" + std::to_string(i) +
                                 "] (k = " + std::to_string(first + static_cast<long long>(i)) +
                                 ") = " + format_value(probs[i]) + "; expected a finite probability >= 0");
      const double y = probs[i] - c, t = sum + y;
      c = (t - sum) - y;
      sum = t;
    }
    if (!(std::abs(sum - 1.0) <= 1e-9))
      throw std::runtime_error(bad + ": probabilities sum to " + format_value(sum) + "; expected 1 within 1e-9");
    std::vector<double> support(probs.size());
    for (std::size_t i = 0; i < support.size(); ++i) support[i] = static_cast<double>(first) + static_cast<double>(i);
    return Distribution::with_trimmed_tails(std::move(support), std::move(probs),
                                            (trimmed & GLINTLAB_TRIMMED_BELOW) != 0,
                                            (trimmed & GLINTLAB_TRIMMED_ABOVE) != 0);
  }

 private:
  std::shared_ptr<const PluginEntry> e_;
};

struct Loaded {
  std::string path;
  void* handle;
  std::vector<std::string> laws;
};

// Loads are serialized; the list lives for the process (its handles are never closed).
std::mutex& load_mutex() {
  static std::mutex m;
  return m;
}
std::vector<Loaded>& loaded() {
  static std::vector<Loaded> list;
  return list;
}

bool valid_name(const char* s) {
  const std::size_t len = strnlen(s, kMaxNameLength + 1);
  if (len == 0 || len > kMaxNameLength) return false;
  if (!((s[0] >= 'a' && s[0] <= 'z') || (s[0] >= 'A' && s[0] <= 'Z'))) return false;
  for (std::size_t i = 0; i < len; ++i) {
    const char ch = s[i];
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_' ||
                    ch == '-' || ch == '.';
    if (!ok) return false;
  }
  return true;
}

// The name as it can be shown in a message (the raw bytes may be anything).
std::string quoted(const char* s) {
  if (!s) return "NULL";
  std::string out = "'";
  for (std::size_t i = 0; s[i] && i < 80; ++i) {
    const char ch = s[i];
    out += (ch >= 32 && ch < 127) ? ch : '?';
  }
  return out + "'";
}

// Releases a library that failed validation (nothing of it was registered).
struct HandleGuard {
  void* handle;
  ~HandleGuard() {
    if (handle) dlclose(handle);
  }
};

}  // namespace

std::vector<std::string> load_plugin(const std::string& path, const std::vector<std::string>& reserved) {
  namespace fs = std::filesystem;
  const std::string where = "plugin '" + path + "'";
  std::error_code ec;
  if (path.empty() || !fs::is_regular_file(path, ec))
    glintlab::throw_invalid_message(where + ": no such file (expected the path of a shared library)");
  // Canonical: "./lib.so" and "/abs/lib.so" are one plugin; and dlopen never searches
  // LD_LIBRARY_PATH for a name that contains a '/'.
  const std::string canonical = fs::canonical(path, ec).string();
  if (ec) glintlab::throw_invalid_message(where + ": " + ec.message());

  std::lock_guard lock(load_mutex());
  for (const auto& l : loaded())
    if (l.path == canonical) return l.laws;

  dlerror();
  HandleGuard guard{dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL)};
  if (!guard.handle) {
    const char* err = dlerror();
    glintlab::throw_invalid_message(where + ": cannot load the library: " + (err ? err : "unknown dlopen error"));
  }
  // The same file under another name (a hard link): dlopen returned the loaded object.
  for (const auto& l : loaded())
    if (l.handle == guard.handle) return l.laws;  // (the guard drops the extra reference)

  dlerror();
  void* sym = dlsym(guard.handle, GLINTLAB_PLUGIN_SYMBOL_V1);
  if (!sym)
    glintlab::throw_invalid_message(where + ": the library does not export " GLINTLAB_PLUGIN_SYMBOL_V1
                                            " (define it with GLINTLAB_PLUGIN from glintlab/plugin.h, with C linkage)");
  glintlab_plugin_laws_v1_fn entry_fn;
  static_assert(sizeof entry_fn == sizeof sym);
  std::memcpy(&entry_fn, &sym, sizeof sym);  // object to function pointer, as POSIX allows

  int count = -1;
  const glintlab_law_v1* table = entry_fn(&count);
  if (count < 1 || count > kMaxLaws)
    throw_invalid(where, GLINTLAB_PLUGIN_SYMBOL_V1 " count", count, "1 to " + std::to_string(kMaxLaws) + " laws");
  if (!table) glintlab::throw_invalid_message(where + ": " GLINTLAB_PLUGIN_SYMBOL_V1 " returned a NULL table");

  // Validate everything before registering anything: a bad plugin leaves no trace.
  std::vector<std::string> taken;
  for (const auto& info : registered_laws()) taken.push_back(info.name);
  const auto origin = [&](const std::string& name) -> std::string {
    for (const auto& l : loaded())
      if (std::find(l.laws.begin(), l.laws.end(), name) != l.laws.end()) return "plugin '" + l.path + "' registered it";
    if (std::find(reserved.begin(), reserved.end(), name) != reserved.end()) return "a Python custom law has it";
    return "a built-in law has it";
  };
  std::vector<std::shared_ptr<const PluginEntry>> entries;
  std::vector<std::string> names;
  for (int i = 0; i < count; ++i) {
    const glintlab_law_v1& law = table[i];
    const std::string field = "laws[" + std::to_string(i) + "].";
    if (!law.name || !valid_name(law.name))
      throw_invalid(where, field + "name", quoted(law.name),
                    "1 to 64 characters among A-Z a-z 0-9 _ - . starting with a letter");
    const std::string name = law.name;
    const std::string here = where + ", law '" + name + "'";
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw_invalid(where, field + "name", "'" + name + "'", "a name used once in the table");
    if (std::find(taken.begin(), taken.end(), name) != taken.end() ||
        std::find(reserved.begin(), reserved.end(), name) != reserved.end())
      throw_invalid(where, field + "name", "'" + name + "'", "a name no registered law uses (" + origin(name) + ")");
    if (law.n_uniforms < 0 || law.n_uniforms > 4) throw_invalid(here, "n_uniforms", law.n_uniforms, "0 to 4");
    if (!law.evaluate) throw_invalid(here, "evaluate", "NULL", "a function");
    const std::string binning = law.binning ? law.binning : "none";
    if (binning != "none" && binning != "round")
      throw_invalid(here, "binning", quoted(law.binning), "'none' or 'round'");
    auto e = std::make_shared<PluginEntry>();
    e->name = name;
    e->path = canonical;
    e->summary =
        std::string(law.summary ? law.summary : "") + " (plugin " + fs::path(canonical).filename().string() + ")";
    e->binning = binning;
    e->n_uniforms = law.n_uniforms;
    e->evaluate = law.evaluate;
    e->pmf = law.pmf;
    entries.push_back(std::move(e));
    names.push_back(name);
  }

  for (const auto& e : entries) {
    register_law({e->name,
                  e->summary,
                  [e](const LawParams& params) -> std::unique_ptr<CountingLaw> {
                    ParamReader(e->name, params).finish();  // plugin laws take no parameters
                    return std::make_unique<PluginLaw>(e);
                  },
                  // Nothing promised (undeclared traits) but how its outputs are binned.
                  {.bin_real = e->binning == "round"}});
  }
  loaded().push_back({canonical, guard.handle, names});
  guard.handle = nullptr;  // kept open for the life of the process
  return names;
}

std::vector<LoadedPlugin> loaded_plugins() {
  std::lock_guard lock(load_mutex());
  std::vector<LoadedPlugin> out;
  for (const auto& l : loaded()) out.push_back({l.path, l.laws});
  return out;
}

}  // namespace glintlab
