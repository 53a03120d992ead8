// The Vulkan compute runner behind shader laws (glintlab/validation/shader.hpp): shaderc compiles
// glintlab's wrapper kernel around the user's function, Vulkan runs it on buffers of (n, p, u).
#include "glintlab/validation/shader.hpp"

#include "glintlab/errors.hpp"

#include <vulkan/vulkan.h>

#include <shaderc/shaderc.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "glintlab/float32.hpp"

namespace glintlab::shader {
namespace {

constexpr std::uint32_t kGroupSize = 64;
constexpr std::size_t kChunkRows = std::size_t{1} << 20;  // rows per submission (16384 groups)
constexpr const char* kInstallHint =
    "install a Vulkan driver: on Debian `apt-get install mesa-vulkan-drivers libvulkan1` (lavapipe, "
    "Vulkan on the CPU), or your GPU vendor's driver";

std::string vk_error(const char* what, VkResult r) {
  return std::string("Vulkan: ") + what + " failed (VkResult " + std::to_string(static_cast<int>(r)) + ")";
}
void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw std::runtime_error(vk_error(what, r));
}

std::string type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete_gpu";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated_gpu";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual_gpu";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// ---------------------------------------------------------------- instance and devices

struct Pipeline {
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  std::vector<std::uint32_t> spirv;
  int unbounded_loops = 0;
};

struct Job;

struct Device {
  VkPhysicalDevice phys = VK_NULL_HANDLE;
  VkDevice dev = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  std::string name, type;
  VkPhysicalDeviceMemoryProperties memory{};
  VkCommandPool pool = VK_NULL_HANDLE;
  std::mutex mutex;  // the queue, the pool, the pipeline cache and the retired jobs
  std::map<std::string, std::shared_ptr<Pipeline>> pipelines;
  std::vector<std::unique_ptr<Job>> retired;  // timed out: freed once their fence signals
};

// Process-wide, created on first use and never destroyed: destroying Vulkan objects from static
// destructors races the driver's own teardown; the operating system reclaims them at exit.
struct Vulkan {
  VkInstance instance = VK_NULL_HANDLE;
  std::vector<VkPhysicalDevice> physical;
  std::map<int, Device*> devices;
  std::string error;  // why there is no instance, when there is none
};

std::mutex g_vulkan_mutex;

Vulkan& vulkan() {
  static Vulkan* v = [] {
    auto* out = new Vulkan;
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "glintlab";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pApplicationInfo = &app;
    const VkResult r = vkCreateInstance(&info, nullptr, &out->instance);
    if (r != VK_SUCCESS) {
      out->instance = VK_NULL_HANDLE;
      out->error = vk_error("vkCreateInstance", r);
      return out;
    }
    std::uint32_t count = 0;
    vkEnumeratePhysicalDevices(out->instance, &count, nullptr);
    out->physical.resize(count);
    if (count) vkEnumeratePhysicalDevices(out->instance, &count, out->physical.data());
    out->physical.resize(count);
    return out;
  }();
  return *v;
}

DeviceInfo describe(int index, VkPhysicalDevice phys) {
  VkPhysicalDeviceProperties props{};
  vkGetPhysicalDeviceProperties(phys, &props);
  DeviceInfo d;
  d.index = index;
  d.name = props.deviceName;
  d.type = type_name(props.deviceType);
  d.api_version = std::to_string(VK_API_VERSION_MAJOR(props.apiVersion)) + "." +
                  std::to_string(VK_API_VERSION_MINOR(props.apiVersion)) + "." +
                  std::to_string(VK_API_VERSION_PATCH(props.apiVersion));
  if (props.apiVersion >= VK_API_VERSION_1_2) {
    VkPhysicalDeviceDriverProperties driver{};
    driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
    VkPhysicalDeviceProperties2 props2{};
    props2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    props2.pNext = &driver;
    vkGetPhysicalDeviceProperties2(phys, &props2);
    d.driver = std::string(driver.driverName) + (driver.driverInfo[0] ? std::string(" ") + driver.driverInfo : "");
  }
  return d;
}

int rank(const std::string& type) {  // "auto" prefers a discrete GPU, then any GPU, then the CPU
  if (type == "discrete_gpu") return 0;
  if (type == "integrated_gpu") return 1;
  if (type == "virtual_gpu") return 2;
  if (type == "cpu") return 3;
  return 4;
}

int choose_device(const std::string& request) {
  Vulkan& v = vulkan();
  if (!v.instance) throw NoVulkanDevice("no Vulkan instance (" + v.error + "); " + kInstallHint);
  if (v.physical.empty()) throw NoVulkanDevice(std::string("no Vulkan device found; ") + kInstallHint);
  std::vector<DeviceInfo> all;
  for (std::size_t i = 0; i < v.physical.size(); ++i) all.push_back(describe(static_cast<int>(i), v.physical[i]));
  std::string known;
  for (const auto& d : all)
    known += (known.empty() ? "" : ", ") + std::to_string(d.index) + ": " + d.name + " (" + d.type + ")";
  auto best = [&](auto keep) {
    int chosen = -1;
    for (const auto& d : all)
      if (keep(d) && (chosen < 0 || rank(d.type) < rank(all[static_cast<std::size_t>(chosen)].type))) chosen = d.index;
    return chosen;
  };
  if (request.empty())
    glintlab::throw_invalid("", "device", "''", "'auto', 'gpu', 'cpu', an index or part of a name among " + known);
  int chosen = -1;
  if (request == "auto") {
    chosen = best([](const DeviceInfo&) { return true; });
  } else if (request == "gpu") {
    chosen = best([](const DeviceInfo& d) { return d.type.find("gpu") != std::string::npos; });
    if (chosen < 0) throw NoVulkanDevice("device = 'gpu' but no Vulkan GPU is present (devices: " + known + ")");
  } else if (request == "cpu") {
    chosen = best([](const DeviceInfo& d) { return d.type == "cpu"; });
    if (chosen < 0)
      throw NoVulkanDevice("device = 'cpu' but no CPU Vulkan device is present (devices: " + known +
                           "); install mesa-vulkan-drivers (lavapipe)");
  } else if (!request.empty() && std::all_of(request.begin(), request.end(), ::isdigit)) {
    chosen = std::stoi(request);
    if (chosen >= static_cast<int>(all.size()))
      glintlab::throw_invalid("", "device", "'" + request + "'", "one of " + known);
  } else {
    for (const auto& d : all)
      if (d.name.find(request) != std::string::npos) {
        chosen = d.index;
        break;
      }
    if (chosen < 0)
      glintlab::throw_invalid("", "device", "'" + request + "'",
                              "'auto', 'gpu', 'cpu', an index or part of a name among " + known);
  }
  return chosen;
}

Device& device(int index) {
  std::lock_guard<std::mutex> lock(g_vulkan_mutex);
  Vulkan& v = vulkan();
  if (auto it = v.devices.find(index); it != v.devices.end()) return *it->second;
  auto d = std::make_unique<Device>();
  d->phys = v.physical[static_cast<std::size_t>(index)];
  const DeviceInfo info = describe(index, d->phys);
  d->name = info.name;
  d->type = info.type;
  vkGetPhysicalDeviceMemoryProperties(d->phys, &d->memory);
  std::uint32_t nfam = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(d->phys, &nfam, nullptr);
  std::vector<VkQueueFamilyProperties> fams(nfam);
  vkGetPhysicalDeviceQueueFamilyProperties(d->phys, &nfam, fams.data());
  bool found = false;
  for (std::uint32_t i = 0; i < nfam && !found; ++i)
    if (fams[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      d->family = i;
      found = true;
    }
  if (!found) throw NoVulkanDevice("Vulkan device '" + d->name + "' has no compute queue");
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo q{};
  q.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  q.queueFamilyIndex = d->family;
  q.queueCount = 1;
  q.pQueuePriorities = &priority;
  VkDeviceCreateInfo info_create{};
  info_create.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  info_create.queueCreateInfoCount = 1;
  info_create.pQueueCreateInfos = &q;
  check(vkCreateDevice(d->phys, &info_create, nullptr, &d->dev), "vkCreateDevice");
  vkGetDeviceQueue(d->dev, d->family, 0, &d->queue);
  VkCommandPoolCreateInfo pool{};
  pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool.queueFamilyIndex = d->family;
  check(vkCreateCommandPool(d->dev, &pool, nullptr, &d->pool), "vkCreateCommandPool");
  Device& out = *d;
  v.devices[index] = d.release();
  return out;
}

// ---------------------------------------------------------------- compilation

std::string wrapper_name(const std::string& language) {
  return language == "hlsl" ? "glintlab_kernel.hlsl" : "glintlab_kernel.comp";
}

bool is_identifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::string strip_bom(std::string text) {  // Visual Studio saves UTF-8 with a byte-order mark
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
  return text;
}

// The offset of the first byte that is not part of well-formed UTF-8 (RFC 3629: no overlong forms, no
// surrogates, nothing above U+10FFFF), or npos. Shader files are UTF-8, included ones too: a byte of
// another encoding is refused naming its offset rather than passed to the compiler as a guess.
std::size_t invalid_utf8(const std::string& text) {
  const auto* b = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned c = b[i];
    std::size_t len = 0;
    unsigned lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
    if (c < 0x80) {
      ++i;
      continue;
    }
    if (c >= 0xC2 && c <= 0xDF)
      len = 2;
    else if (c >= 0xE0 && c <= 0xEF) {
      len = 3;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      len = 4;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    } else
      return i;
    if (i + len > n) return i;
    if (b[i + 1] < lo || b[i + 1] > hi) return i;
    for (std::size_t k = 2; k < len; ++k)
      if (b[i + k] < 0x80 || b[i + k] > 0xBF) return i;
    i += len;
  }
  return std::string::npos;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return strip_bom(s.str());
}

// A bound on macro expansion. glslang expands macros with no limit and cannot be interrupted:
// `#define A1 A0 A0`, `#define A2 A1 A1`, ... `A40` asks for 2^40 tokens, and memory runs out before any
// timeout could act (compilation runs in this process). Every file the compiler reads passes through
// the Includer first (the user's file too: the wrapper includes it), so the #define lines of every
// file, and the -D defines, are scanned before the preprocessor sees them, and a macro whose
// replacement, fully expanded, would exceed kMaxMacroTokens tokens is refused by name. The bound
// counts each replacement list's tokens with every macro in it replaced by its own bound; a
// function-like macro's parameters count one token each, and a macro already on the expansion path
// counts one (the preprocessor does not expand it again); inside the parentheses of a call of a
// function-like macro every token counts as many times as the macro repeats a parameter, so nested
// calls F(F(F(x))) multiply, in a replacement list and in each file's code alike.
constexpr double kMaxMacroTokens = 4194304.0;  // 2^22 tokens: tens of MB of text

class MacroBounds {
 public:
  // The #define lines of one source text (comments and line continuations removed first).
  void add_source(const std::string& text) {
    std::istringstream lines(strip_comments(text));
    std::string code;  // the lines that are not directives: where the macros get called
    for (std::string line; std::getline(lines, line);) {
      std::size_t i = line.find_first_not_of(" \t");
      if (i == std::string::npos || line[i] != '#') {
        code += line;
        code += '\n';
        continue;
      }
      i = line.find_first_not_of(" \t", i + 1);
      if (i == std::string::npos || line.compare(i, 6, "define") != 0) continue;
      i = line.find_first_not_of(" \t", i + 6);
      if (i == std::string::npos || !ident_start(line[i])) continue;
      std::size_t e = i;
      while (e < line.size() && ident_char(line[e])) ++e;
      const std::string name = line.substr(i, e - i);
      std::set<std::string> params;
      if (e < line.size() && line[e] == '(') {  // function-like: no space before the parenthesis
        const std::size_t close = line.find(')', e);
        const std::string list = line.substr(e + 1, (close == std::string::npos ? line.size() : close) - e - 1);
        for (const auto& t : tokens(list)) params.insert(t);
        e = close == std::string::npos ? line.size() : close + 1;
      }
      define(name, line.substr(e), std::move(params));
    }
    std::map<std::string, double> memo;
    std::set<std::string> open;
    code_tokens_ = std::max(code_tokens_, sequence(tokens(code), {}, "", open, memo));
  }
  void define(const std::string& name, const std::string& body, std::set<std::string> params = {}) {
    macros_[name] = Macro{tokens(body), std::move(params)};
  }
  // The first macro (in name order) whose bound exceeds kMaxMacroTokens, with its bound; "" if none.
  std::string over(double& bound, const std::string& file) const {
    std::map<std::string, double> memo;
    for (const auto& entry : macros_) {
      std::set<std::string> open;
      bound = size(entry.first, open, memo);
      if (bound > kMaxMacroTokens)
        return "macro " + entry.first +
               (file.empty() ? " (from defines)" : " (defined in " + file + " or a file before it)");
    }
    bound = code_tokens_;
    if (bound > kMaxMacroTokens) return "the code of " + file + " (nested calls of function-like macros)";
    return "";
  }
  // "" while every bound holds; else the refusal, naming the macro and `file` (the file just read,
  // "" for the defines).
  std::string message(const std::string& file) const {
    double bound = 0;
    const std::string name = over(bound, file);
    if (name.empty()) return "";
    char n[32];
    std::snprintf(n, sizeof n, "%.3g", bound);
    return name + " expands to " + n + " tokens, more than " + std::to_string(static_cast<long long>(kMaxMacroTokens)) +
           " (each macro that repeats another multiplies its size: the compiler would run out of memory); "
           "define it with fewer repetitions or as a function";
  }

 private:
  struct Macro {
    std::vector<std::string> body;
    std::set<std::string> params;
  };
  static bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
  static bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }
  // Identifiers, numbers and string literals as one token each; any other character as one token
  // (an over-count, on the safe side of the bound).
  static std::vector<std::string> tokens(const std::string& s) {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < s.size();) {
      const char c = s[i];
      std::size_t e = i + 1;
      if (std::isspace(static_cast<unsigned char>(c))) {
        i = e;
        continue;
      }
      if (ident_start(c) || std::isdigit(static_cast<unsigned char>(c)))
        while (e < s.size() && (ident_char(s[e]) || s[e] == '.')) ++e;
      else if (c == '"')
        while (e < s.size() && s[e++] != '"') {}
      out.push_back(s.substr(i, e - i));
      i = e;
    }
    return out;
  }
  static std::string strip_comments(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\\' && i + 1 < text.size() && text[i + 1] == '\n') {
        ++i;
        continue;
      }
      if (text[i] == '\\' && i + 2 < text.size() && text[i + 1] == '\r' && text[i + 2] == '\n') {
        i += 2;
        continue;
      }
      if (text[i] == '/' && i + 1 < text.size() && text[i + 1] == '/') {
        while (i < text.size() && text[i] != '\n') ++i;
        if (i < text.size()) out += '\n';
        continue;
      }
      if (text[i] == '/' && i + 1 < text.size() && text[i + 1] == '*') {
        const std::size_t end = text.find("*/", i + 2);
        const std::size_t stop = end == std::string::npos ? text.size() : end + 2;
        out += ' ';
        out.append(static_cast<std::size_t>(std::count(text.begin() + static_cast<std::ptrdiff_t>(i),
                                                       text.begin() + static_cast<std::ptrdiff_t>(stop), '\n')),
                   '\n');
        i = stop - 1;
        continue;
      }
      out += text[i];
    }
    return out;
  }
  // The expanded size of a token sequence: a macro counts its bound, and every token inside the
  // arguments of a call of a function-like macro counts as many times as that macro repeats a
  // parameter (nested calls multiply). With `count_only` set, only that identifier (a parameter)
  // counts: the number of copies of it the sequence makes.
  double sequence(const std::vector<std::string>& ts, const std::set<std::string>& params,
                  const std::string& count_only, std::set<std::string>& open,
                  std::map<std::string, double>& memo) const {
    double total = 0, weight = 1;
    std::vector<double> weights;  // the weight outside each open parenthesis
    double call = 0;              // the repetition of the function-like macro whose '(' comes next
    for (std::size_t k = 0; k < ts.size() && total <= 1e300; ++k) {
      const std::string& t = ts[k];
      const bool counts = count_only.empty() || t == count_only;
      // Parentheses count at the weight outside them (a call's own are not copied with its argument).
      if (t == "(") {
        if (count_only.empty()) total += weight;
        weights.push_back(weight);
        if (call > 0) weight *= call;
        call = 0;
        continue;
      }
      call = 0;
      if (t == ")") {
        if (!weights.empty()) weight = weights.back(), weights.pop_back();
        if (count_only.empty()) total += weight;
        continue;
      }
      const auto it = macros_.find(t);
      if (!ident_start(t[0]) || params.count(t) || it == macros_.end() || open.count(t)) {
        if (counts) total += weight;
        continue;
      }
      if (count_only.empty()) total += weight * size(t, open, memo);
      if (!it->second.params.empty() && k + 1 < ts.size() && ts[k + 1] == "(") call = repetition(t, open, memo);
    }
    return total;
  }
  // A macro's bound: its replacement's expanded size, parameters one token each.
  double size(const std::string& name, std::set<std::string>& open, std::map<std::string, double>& memo) const {
    const auto it = macros_.find(name);
    if (it == macros_.end() || open.count(name)) return 1.0;
    if (const auto m = memo.find(name); m != memo.end()) return m->second;
    open.insert(name);
    const double s = sequence(it->second.body, it->second.params, "", open, memo);
    open.erase(name);
    memo[name] = s;
    return s;
  }
  // The most copies a function-like macro makes of one of its arguments (at least 1).
  double repetition(const std::string& name, std::set<std::string>& open, std::map<std::string, double>& memo) const {
    const auto it = macros_.find(name);
    const std::string key = "(" + name;  // its own memo entries, apart from the sizes
    if (const auto m = memo.find(key); m != memo.end()) return m->second;
    open.insert(name);
    double r = 1;
    for (const auto& p : it->second.params)
      r = std::max(r, sequence(it->second.body, it->second.params, p, open, memo));
    open.erase(name);
    memo[key] = r;
    return r;
  }
  std::map<std::string, Macro> macros_;
  double code_tokens_ = 0;  // the largest expanded size of one file's code so far
};

// What the includes of one preprocess or compile have done so far. glslang reports the depth of each
// #include it asks for (1: the user's file, included by the wrapper), so the open chain is exact
// without relying on when it releases a file.
struct IncludeState {
  std::vector<std::string> chain;  // chain[d - 1]: the file open at depth d
  int count = 0;
  std::string failure;  // once an include limit is hit, every later #include fails with it (bounded work)
  std::vector<std::pair<std::string, std::string>>* included = nullptr;
  MacroBounds macros;         // every #define seen so far (and the -D defines)
  std::string macro_failure;  // set when a macro's expansion bound is exceeded (then nothing more is served)
};

std::string short_name(const std::string& path) {
  const std::string name = std::filesystem::path(path).filename().string();
  return name.empty() ? path : name;
}

// Serves the user's code under its own name (so the compiler's messages say file:line) and resolves
// its #include "x" relative to the including file, then the include directories (or, for a sealed
// spec, among the recorded include_files only).
class Includer final : public shaderc::CompileOptions::IncluderInterface {
 public:
  Includer(const KernelSpec& spec, std::shared_ptr<IncludeState> state)
      : user_name_(spec.source_name), user_source_(strip_bom(spec.source)), dirs_(spec.include_dirs),
        sealed_(spec.include_files.begin(), spec.include_files.end()), is_sealed_(!spec.include_files.empty()),
        state_(std::move(state)) {}

  shaderc_include_result* GetInclude(const char* requested, shaderc_include_type, const char* requesting,
                                     std::size_t depth) override {
    auto* r = new Result;
    IncludeState& st = *state_;
    if (user_name_ == requested && std::string(requesting).rfind("glintlab_kernel.", 0) == 0) {
      r->name = user_name_;
      r->content = user_source_;
    } else if (!st.failure.empty()) {
      r->content = st.failure;
    } else {
      std::vector<std::filesystem::path> candidates;
      const std::filesystem::path from(requesting);
      if (from.has_parent_path())
        candidates.push_back(from.parent_path() / requested);
      else
        candidates.push_back(std::filesystem::path(requested));
      for (const auto& d : dirs_) candidates.push_back(std::filesystem::path(d) / requested);
      std::string found, content;
      for (const auto& c : candidates) {
        if (is_sealed_) {
          if (auto it = sealed_.find(c.string()); it != sealed_.end()) {
            found = it->first;
            content = it->second;
            break;
          }
          continue;
        }
        std::error_code ec;
        if (std::filesystem::is_regular_file(c, ec)) {
          found = c.string();
          content = read_file(c);
          break;
        }
      }
      const std::size_t bad = found.empty() ? std::string::npos : invalid_utf8(content);
      if (found.empty()) {
        r->content = std::string("cannot find include file '") + requested + "'" +
                     (is_sealed_ ? " among the files recorded when the law was first compiled" : "");
      } else if (bad != std::string::npos) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02x", static_cast<unsigned char>(content[bad]));
        r->content =
            found + ": byte " + hex + " at offset " + std::to_string(bad) + " (line " +
            std::to_string(1 + std::count(content.begin(), content.begin() + static_cast<std::ptrdiff_t>(bad), '\n')) +
            ") is not UTF-8; expected a UTF-8 file (save it as UTF-8)";
      } else if (static_cast<int>(depth) > kMaxIncludeDepth || ++st.count > kMaxIncludes) {
        st.failure = limit_message(found, static_cast<int>(depth) > kMaxIncludeDepth);
        r->content = st.failure;
      } else {
        r->name = found;
        r->content = std::move(content);
        if (st.included &&
            std::none_of(st.included->begin(), st.included->end(), [&](const auto& f) { return f.first == found; }))
          st.included->emplace_back(found, r->content);
      }
    }
    if (!r->name.empty()) {
      // Scan the file's macros before the preprocessor expands any of them (the bound above).
      st.macros.add_source(r->content);
      if (st.macro_failure.empty()) st.macro_failure = st.macros.message(short_name(r->name));
      if (!st.macro_failure.empty()) {
        r->name.clear();
        r->content = st.macro_failure;
      }
    }
    if (!r->name.empty()) {
      st.chain.resize(depth > 0 ? depth - 1 : 0);
      st.chain.push_back(r->name);
    }
    r->result.source_name = r->name.c_str();
    r->result.source_name_length = r->name.size();
    r->result.content = r->content.c_str();
    r->result.content_length = r->content.size();
    r->result.user_data = r;
    return &r->result;
  }
  void ReleaseInclude(shaderc_include_result* data) override { delete static_cast<Result*>(data->user_data); }

 private:
  std::string limit_message(const std::string& next, bool depth) const {
    const auto& chain = state_->chain;
    // The cycle: through `next` (its latest opening), else the latest file open twice in the chain
    // (the limit may trip on a leaf included from inside a cycle).
    std::vector<std::string> full = chain;
    full.push_back(next);
    for (std::size_t end = full.size(); end-- > 1;)
      for (std::size_t i = end; i-- > 0;)
        if (full[i] == full[end]) {
          std::string cycle;
          for (std::size_t k = i; k <= end; ++k) cycle += (k > i ? " -> " : "") + short_name(full[k]);
          return "#include cycle " + cycle + " (" + full[end] +
                 " includes itself through this chain; #pragma "
                 "once is not honoured by the shader compiler: guard the file with #ifndef/#define or remove "
                 "the include)";
        }
    std::string path;
    for (const auto& f : full) path += (path.empty() ? "" : " -> ") + short_name(f);
    if (depth) return "#include nested deeper than " + std::to_string(kMaxIncludeDepth) + " files (" + path + ")";
    return "more than " + std::to_string(kMaxIncludes) + " #include directives processed (last: " + path + ")";
  }
  struct Result {
    shaderc_include_result result{};
    std::string name, content;
  };
  std::string user_name_, user_source_;
  std::vector<std::string> dirs_;
  std::map<std::string, std::string> sealed_;
  bool is_sealed_ = false;
  std::shared_ptr<IncludeState> state_;
};

std::string expected_signature(const std::string& language, const std::string& entry) {
  return language == "hlsl" ? "float " + entry + "(float n, float p, float4 u)"
                            : "float " + entry + "(float n, float p, vec4 u)";
}

shaderc::CompileOptions options(const KernelSpec& spec, std::shared_ptr<IncludeState> state) {
  shaderc::CompileOptions o;
  o.SetSourceLanguage(spec.language == "hlsl" ? shaderc_source_language_hlsl : shaderc_source_language_glsl);
  o.SetTargetEnvironment(shaderc_target_env_vulkan, shaderc_env_version_vulkan_1_0);
  o.SetOptimizationLevel(shaderc_optimization_level_performance);
  o.SetGenerateDebugInfo();  // no effect on the code; keeps names in the SPIR-V for inspection
  // A define without a value (Python None, the empty string) is `#define NAME`, as `-D NAME` would be.
  for (const auto& [name, value] : spec.defines) o.AddMacroDefinition(name, value);
  o.AddMacroDefinition("GLINTLAB_N_UNIFORMS", std::to_string(spec.n_uniforms));
  o.SetIncluder(std::make_unique<Includer>(spec, std::move(state)));
  return o;
}

[[noreturn]] void compile_failure(const KernelSpec& spec, const std::string& messages,
                                  const std::string& signature = "") {
  // Only when every error is inside glintlab's wrapper did the call to the entry not match; an error
  // in the user's code (a missing `;`) also breaks the wrapper's call, and is the one to show.
  const std::string wrapper = wrapper_name(spec.language) + ":";
  bool wrapper_only = messages.find(wrapper) != std::string::npos;
  std::istringstream lines(messages);
  for (std::string line; std::getline(lines, line);)
    if (line.find("error") != std::string::npos && line.rfind(wrapper, 0) != 0 &&
        line.find("error(s) generated") == std::string::npos && line.find("errors generated") == std::string::npos)
      wrapper_only = false;
  if (wrapper_only)
    glintlab::throw_invalid_message("shader " + spec.source_name + ": no function " + spec.entry +
                                    " with the expected signature " +
                                    (signature.empty() ? expected_signature(spec.language, spec.entry) : signature) +
                                    " (" + spec.language + "); the compiler says:\n" + messages);
  glintlab::throw_invalid_message("shader " + spec.source_name + " does not compile (" + spec.language +
                                  "); the compiler says:\n" + messages);
}

std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// ---------------------------------------------------------------- one call's resources

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
  VkDeviceSize size = 0;
};

std::uint32_t memory_type(const Device& d, std::uint32_t bits, bool readback) {
  const VkMemoryPropertyFlags need = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  int fallback = -1;
  for (std::uint32_t i = 0; i < d.memory.memoryTypeCount; ++i) {
    if (!(bits & (1u << i)) || (d.memory.memoryTypes[i].propertyFlags & need) != need) continue;
    const bool cached = d.memory.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    if (readback == cached) return i;
    if (fallback < 0) fallback = static_cast<int>(i);
  }
  if (fallback < 0) throw std::runtime_error("Vulkan: device '" + d.name + "' has no host-visible coherent memory");
  return static_cast<std::uint32_t>(fallback);
}

struct Job {
  Device& d;
  Buffer buffers[4];  // n, p, u, out
  VkDescriptorPool descriptor_pool = VK_NULL_HANDLE;
  VkCommandBuffer command = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;

  explicit Job(Device& device) : d(device) {}
  ~Job() {
    if (fence) vkDestroyFence(d.dev, fence, nullptr);
    if (command) vkFreeCommandBuffers(d.dev, d.pool, 1, &command);
    if (descriptor_pool) vkDestroyDescriptorPool(d.dev, descriptor_pool, nullptr);
    for (auto& b : buffers) {
      if (b.mapped) vkUnmapMemory(d.dev, b.memory);
      if (b.buffer) vkDestroyBuffer(d.dev, b.buffer, nullptr);
      if (b.memory) vkFreeMemory(d.dev, b.memory, nullptr);
    }
  }
  void make_buffer(int i, VkDeviceSize size, bool readback) {
    Buffer& b = buffers[i];
    b.size = size;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    check(vkCreateBuffer(d.dev, &info, nullptr, &b.buffer), "vkCreateBuffer");
    VkMemoryRequirements req{};
    vkGetBufferMemoryRequirements(d.dev, b.buffer, &req);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = memory_type(d, req.memoryTypeBits, readback);
    check(vkAllocateMemory(d.dev, &alloc, nullptr, &b.memory), "vkAllocateMemory");
    check(vkBindBufferMemory(d.dev, b.buffer, b.memory, 0), "vkBindBufferMemory");
    check(vkMapMemory(d.dev, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
  }
  // Binds the four buffers as storage buffers 0-3 of a descriptor set of `layout` and allocates the
  // command buffer and fence of this job (both kernels' runs share this set-up). Returns the set.
  VkDescriptorSet bind(VkDescriptorSetLayout layout) {
    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 4};
    VkDescriptorPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool_info.maxSets = 1;
    pool_info.poolSizeCount = 1;
    pool_info.pPoolSizes = &size;
    check(vkCreateDescriptorPool(d.dev, &pool_info, nullptr, &descriptor_pool), "vkCreateDescriptorPool");
    VkDescriptorSetAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    alloc.descriptorPool = descriptor_pool;
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &layout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    check(vkAllocateDescriptorSets(d.dev, &alloc, &set), "vkAllocateDescriptorSets");
    VkDescriptorBufferInfo infos[4];
    VkWriteDescriptorSet writes[4]{};
    for (int i = 0; i < 4; ++i) {
      infos[i] = {buffers[i].buffer, 0, VK_WHOLE_SIZE};
      writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      writes[i].dstSet = set;
      writes[i].dstBinding = static_cast<std::uint32_t>(i);
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(d.dev, 4, writes, 0, nullptr);
    VkCommandBufferAllocateInfo cmd{};
    cmd.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cmd.commandPool = d.pool;
    cmd.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cmd.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(d.dev, &cmd, &command), "vkAllocateCommandBuffers");
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    check(vkCreateFence(d.dev, &fence_info, nullptr, &fence), "vkCreateFence");
    return set;
  }
};

void reap(Device& d);

// With d.mutex held, before a submission: an earlier kernel that passed its timeout and still runs
// would delay this call's kernel, and a timeout then would blame this one. Waits for the earlier one
// within this call's timeout, else throws ShaderDeviceBusy.
void wait_for_retired(Device& d, double timeout_s);

void reap(Device& d) {  // with d.mutex held
  std::erase_if(d.retired,
                [&](const std::unique_ptr<Job>& j) { return vkGetFenceStatus(d.dev, j->fence) == VK_SUCCESS; });
}

void wait_for_retired(Device& d, double timeout_s) {
  reap(d);
  if (d.retired.empty()) return;
  std::vector<VkFence> fences;
  for (const auto& j : d.retired) fences.push_back(j->fence);
  const auto timeout_ns = static_cast<std::uint64_t>(std::min(timeout_s, 1e9) * 1e9);
  const VkResult w =
      vkWaitForFences(d.dev, static_cast<std::uint32_t>(fences.size()), fences.data(), VK_TRUE, timeout_ns);
  if (w == VK_TIMEOUT) {
    std::ostringstream msg;
    msg << "device '" << d.name << "' is still busy with an earlier kernel that passed its own timeout; this "
        << "call waited timeout = " << timeout_s << " s for it and its kernel never ran (retry later, with a "
        << "longer timeout, or in a new process)";
    throw ShaderDeviceBusy(msg.str());
  }
  check(w, "vkWaitForFences");
  reap(d);
}

struct Push {
  std::uint32_t count, n_stride, p_stride, pad;
};

}  // namespace

// ---------------------------------------------------------------- public

std::vector<DeviceInfo> vulkan_devices() {
  std::lock_guard<std::mutex> lock(g_vulkan_mutex);
  Vulkan& v = vulkan();
  std::vector<DeviceInfo> out;
  for (std::size_t i = 0; i < v.physical.size(); ++i) out.push_back(describe(static_cast<int>(i), v.physical[i]));
  return out;
}

std::string wrapper_source(const std::string& language, const std::string& entry, const std::string& include_name) {
  std::ostringstream s;
  // Bindings: 0 n, 1 p (one float per row, or one for all: stride 0), 2 u (float4 per row), 3 counts.
  // HLSL's push constant is a ConstantBuffer<>: glslang puts a plain global struct marked
  // [[vk::push_constant]] into the "$Global" uniform buffer at set 0, binding 0 instead (where n's
  // storage buffer is bound), which the resource check below refuses.
  if (language == "hlsl") {
    s << "#include \"" << include_name << "\"\n"
      << "struct GlintlabPush { uint count; uint n_stride; uint p_stride; uint pad; };\n"
      << "[[vk::push_constant]] ConstantBuffer<GlintlabPush> glintlab_push;\n"
      << "[[vk::binding(0, 0)]] StructuredBuffer<float> glintlab_n;\n"
      << "[[vk::binding(1, 0)]] StructuredBuffer<float> glintlab_p;\n"
      << "[[vk::binding(2, 0)]] StructuredBuffer<float4> glintlab_u;\n"
      << "[[vk::binding(3, 0)]] RWStructuredBuffer<float> glintlab_k;\n"
      << "[numthreads(" << kGroupSize << ", 1, 1)]\n"
      << "void glintlab_main(uint3 glintlab_id : SV_DispatchThreadID) {\n"
      << "  uint i = glintlab_id.x;\n"
      << "  if (i >= glintlab_push.count) return;\n"
      << "  float n = glintlab_n[i * glintlab_push.n_stride];\n"
      << "  float p = glintlab_p[i * glintlab_push.p_stride];\n"
      << "  float4 u = glintlab_u[i];\n"
      << "  glintlab_k[i] = " << entry << "(n, p, u);\n"
      << "}\n";
  } else {
    s << "#version 450\n"
      << "#extension GL_GOOGLE_include_directive : require\n"
      << "#include \"" << include_name << "\"\n"
      << "layout(local_size_x = " << kGroupSize << ") in;\n"
      << "layout(push_constant) uniform GlintlabPush { uint count; uint n_stride; uint p_stride; uint pad; } "
         "glintlab_push;\n"
      << "layout(std430, set = 0, binding = 0) readonly buffer GlintlabN { float glintlab_n[]; };\n"
      << "layout(std430, set = 0, binding = 1) readonly buffer GlintlabP { float glintlab_p[]; };\n"
      << "layout(std430, set = 0, binding = 2) readonly buffer GlintlabU { vec4 glintlab_u[]; };\n"
      << "layout(std430, set = 0, binding = 3) writeonly buffer GlintlabK { float glintlab_k[]; };\n"
      << "void main() {\n"
      << "  uint i = gl_GlobalInvocationID.x;\n"
      << "  if (i >= glintlab_push.count) return;\n"
      << "  float k = " << entry
      << "(glintlab_n[i * glintlab_push.n_stride], glintlab_p[i * glintlab_push.p_stride], glintlab_u[i]);\n"
      << "  glintlab_k[i] = k;\n"
      << "}\n";
  }
  return s.str();
}

void validate_spec(const KernelSpec& spec) {
  if (spec.language != "hlsl" && spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'hlsl' or 'glsl'");
  if (!is_identifier(spec.entry)) glintlab::throw_invalid("", "entry", "'" + spec.entry + "'", "a function name");
  if (spec.n_uniforms < 0 || spec.n_uniforms > 4)
    glintlab::throw_invalid("", "n_uniforms", std::to_string(spec.n_uniforms), "0 to 4");
  for (const auto& [name, value] : spec.defines) {
    if (!is_identifier(name))
      glintlab::throw_invalid_message("defines: name '" + name + "' is invalid; expected an identifier");
    if (value.find_first_of("\r\n") != std::string::npos)
      glintlab::throw_invalid_message("defines: " + name + " = '" + value +
                                      "' is invalid; expected a value on one line");
  }
  if (spec.source_name.empty() || spec.source_name.rfind("glintlab_kernel.", 0) == 0)
    glintlab::throw_invalid("", "source_name", "'" + spec.source_name + "'", "a file name");
}

std::string preprocess(const KernelSpec& spec, const std::string& wrapper,
                       std::vector<std::pair<std::string, std::string>>* included, const std::string& signature) {
  auto state = std::make_shared<IncludeState>();
  state->included = included;
  for (const auto& [name, value] : spec.defines) state->macros.define(name, value);
  if (const std::string m = state->macros.message(""); !m.empty())
    glintlab::throw_invalid_message("shader " + spec.source_name + ": " + m);
  shaderc::Compiler compiler;
  auto pre = compiler.PreprocessGlsl(wrapper, shaderc_glsl_compute_shader, wrapper_name(spec.language).c_str(),
                                     options(spec, state));
  if (!state->macro_failure.empty())
    glintlab::throw_invalid_message("shader " + spec.source_name + ": " + state->macro_failure);
  if (pre.GetCompilationStatus() != shaderc_compilation_status_success)
    compile_failure(spec, pre.GetErrorMessage(), signature);
  return std::string(pre.cbegin(), pre.cend());
}

std::vector<std::uint32_t> compile_spirv(const KernelSpec& spec, const std::string& wrapper,
                                         const std::string& entry_point, const std::string& signature) {
  shaderc::Compiler compiler;
  auto res = compiler.CompileGlslToSpv(wrapper, shaderc_glsl_compute_shader, wrapper_name(spec.language).c_str(),
                                       entry_point.c_str(), options(spec, std::make_shared<IncludeState>()));
  if (res.GetCompilationStatus() != shaderc_compilation_status_success)
    compile_failure(spec, res.GetErrorMessage(), signature);
  return std::vector<std::uint32_t>(res.cbegin(), res.cend());
}

// ---------------------------------------------------------------- SPIR-V inspection
namespace {
// The few opcodes and enumerants read here, by their numbers in the SPIR-V specification (section 3).
namespace spv {
constexpr std::uint32_t kMagic = 0x07230203;
enum Op : std::uint32_t {
  Name = 5,
  TypeInt = 21,
  TypeFloat = 22,
  TypeStruct = 30,
  TypePointer = 32,
  Constant = 43,
  Variable = 59,
  Decorate = 71,
  IAdd = 128,
  FAdd = 129,
  ISub = 130,
  FSub = 131,
  IEqual = 170,
  INotEqual = 171,
  FOrdEqual = 180,
  FUnordNotEqual = 183,
  FUnordGreaterThanEqual = 191,
  Phi = 245,
  LoopMerge = 246,
  Label = 248,
  Branch = 249,
  BranchConditional = 250,
};
enum Storage : std::uint32_t { UniformConstant = 0, Uniform = 2, PushConstant = 9, StorageBuffer = 12 };
enum Decoration : std::uint32_t { BufferBlock = 3, Binding = 33, DescriptorSet = 34 };
}  // namespace spv

struct Instruction {
  std::uint32_t op = 0;
  std::vector<std::uint32_t> w;  // the operand words (after the opcode word)
};

std::vector<Instruction> instructions(const std::vector<std::uint32_t>& code) {
  if (code.size() < 5 || code[0] != spv::kMagic) glintlab::throw_invalid_message("not a SPIR-V module");
  std::vector<Instruction> out;
  for (std::size_t i = 5; i < code.size();) {
    const std::uint32_t count = code[i] >> 16;
    if (count == 0 || i + count > code.size()) glintlab::throw_invalid_message("truncated SPIR-V module");
    out.push_back(
        {code[i] & 0xFFFFu, std::vector<std::uint32_t>(code.begin() + static_cast<std::ptrdiff_t>(i) + 1,
                                                       code.begin() + static_cast<std::ptrdiff_t>(i + count))});
    i += count;
  }
  return out;
}

std::string literal_string(const std::vector<std::uint32_t>& w, std::size_t from) {
  std::string s;
  for (std::size_t i = from; i < w.size(); ++i)
    for (int b = 0; b < 4; ++b) {
      const char c = static_cast<char>((w[i] >> (8 * b)) & 0xFF);
      if (!c) return s;
      s += c;
    }
  return s;
}
}  // namespace

std::vector<SpirvResource> spirv_resources(const std::vector<std::uint32_t>& spirv) {
  std::map<std::uint32_t, std::string> names;
  std::map<std::uint32_t, int> sets, bindings;
  std::map<std::uint32_t, bool> buffer_block;
  std::map<std::uint32_t, std::uint32_t> pointee;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> variables;  // (result type, id) of resource variables
  std::map<std::uint32_t, std::uint32_t> storage;
  for (const auto& in : instructions(spirv)) {
    if (in.op == spv::Name && in.w.size() >= 2) names[in.w[0]] = literal_string(in.w, 1);
    if (in.op == spv::Decorate && in.w.size() >= 2) {
      if (in.w[1] == spv::DescriptorSet && in.w.size() >= 3) sets[in.w[0]] = static_cast<int>(in.w[2]);
      if (in.w[1] == spv::Binding && in.w.size() >= 3) bindings[in.w[0]] = static_cast<int>(in.w[2]);
      if (in.w[1] == spv::BufferBlock) buffer_block[in.w[0]] = true;
    }
    if (in.op == spv::TypePointer && in.w.size() >= 3) pointee[in.w[0]] = in.w[2];
    if (in.op == spv::Variable && in.w.size() >= 3) {
      const std::uint32_t sc = in.w[2];
      if (sc == spv::UniformConstant || sc == spv::Uniform || sc == spv::PushConstant || sc == spv::StorageBuffer) {
        variables.emplace_back(in.w[0], in.w[1]);
        storage[in.w[1]] = sc;
      }
    }
  }
  std::vector<SpirvResource> out;
  for (const auto& [type, id] : variables) {
    SpirvResource r;
    const std::uint32_t block = pointee.count(type) ? pointee[type] : 0;
    r.name = names.count(id) ? names[id] : "";
    if (r.name.empty() && names.count(block)) r.name = names[block];
    if (r.name.empty()) r.name = "%" + std::to_string(id);
    const std::uint32_t sc = storage[id];
    r.kind = sc == spv::PushConstant                                   ? "push constant"
             : sc == spv::UniformConstant                              ? "sampler or image"
             : (sc == spv::StorageBuffer || buffer_block.count(block)) ? "storage buffer"
                                                                       : "uniform buffer";
    if (sets.count(id)) r.set = sets[id];
    if (bindings.count(id)) r.binding = bindings[id];
    out.push_back(r);
  }
  return out;
}

std::vector<SpirvResource> wrapper_resources() {
  // HLSL names its buffers' variables; GLSL's blocks are anonymous, so their block type names count.
  std::vector<SpirvResource> out{{"glintlab_push", "push constant", -1, -1}};
  const char* hlsl[] = {"glintlab_n", "glintlab_p", "glintlab_u", "glintlab_k"};
  const char* glsl[] = {"GlintlabN", "GlintlabP", "GlintlabU", "GlintlabK"};
  for (int b = 0; b < 4; ++b) {
    out.push_back({hlsl[b], "storage buffer", 0, b});
    out.push_back({glsl[b], "storage buffer", 0, b});
  }
  return out;
}

void require_resources(const std::vector<std::uint32_t>& spirv, const std::vector<SpirvResource>& allowed,
                       const std::string& source_name, const std::string& contract) {
  for (const auto& r : spirv_resources(spirv)) {
    const bool ok = std::any_of(allowed.begin(), allowed.end(), [&](const SpirvResource& a) {
      return a.name == r.name && a.kind == r.kind && a.set == r.set && a.binding == r.binding;
    });
    if (ok) continue;
    std::ostringstream msg;
    msg << "shader " << source_name << ": resource '" << r.name << "' (" << r.kind;
    if (r.set >= 0 || r.binding >= 0) msg << ", set " << r.set << ", binding " << r.binding;
    msg << ") is not bound by glintlab; expected " << contract;
    glintlab::throw_invalid_message(msg.str());
  }
}

int unbounded_loops(const std::vector<std::uint32_t>& spirv) {
  const auto ins = instructions(spirv);
  std::map<std::uint32_t, std::size_t> def;                    // result id -> instruction
  std::map<std::uint32_t, std::size_t> terminator;             // block label -> its branch
  std::vector<std::pair<std::uint32_t, std::uint32_t>> loops;  // (header block, merge block)
  std::uint32_t block = 0;
  for (std::size_t i = 0; i < ins.size(); ++i) {
    const auto& in = ins[i];
    switch (in.op) {
      case spv::TypeInt:
      case spv::TypeFloat:
        if (!in.w.empty()) def[in.w[0]] = i;
        break;
      case spv::Constant:
      case spv::Phi:
      case spv::IAdd:
      case spv::FAdd:
      case spv::ISub:
      case spv::FSub:
        if (in.w.size() >= 2) def[in.w[1]] = i;
        break;
      case spv::Label:
        if (!in.w.empty()) block = in.w[0];
        break;
      case spv::LoopMerge:
        if (!in.w.empty()) loops.emplace_back(block, in.w[0]);
        break;
      case spv::Branch:
      case spv::BranchConditional: terminator[block] = i; break;
      default:
        if (in.op >= spv::IEqual && in.op <= spv::FUnordGreaterThanEqual && in.w.size() >= 2) def[in.w[1]] = i;
    }
  }
  auto get = [&](std::uint32_t id, std::uint32_t op) -> const Instruction* {
    auto it = def.find(id);
    return it != def.end() && ins[it->second].op == op ? &ins[it->second] : nullptr;
  };
  auto constant = [&](std::uint32_t id, double& value) {  // a 32-bit int, uint or float constant
    const Instruction* c = get(id, spv::Constant);
    if (!c || c->w.size() != 3) return false;
    const Instruction* t = nullptr;
    if ((t = get(c->w[0], spv::TypeInt))) {
      value = t->w.size() >= 3 && t->w[2] ? static_cast<double>(static_cast<std::int32_t>(c->w[2])) : c->w[2];
      return t->w[1] == 32;
    }
    if ((t = get(c->w[0], spv::TypeFloat)) && t->w[1] == 32) {
      float f;
      std::memcpy(&f, &c->w[2], sizeof f);
      value = f;
      return std::isfinite(value);
    }
    return false;
  };
  // x = phi + constant (or phi - constant): the phi and the signed step.
  auto stepped = [&](std::uint32_t id, std::uint32_t& phi, double& step) {
    auto it = def.find(id);
    if (it == def.end()) return false;
    const auto& in = ins[it->second];
    if (in.op != spv::IAdd && in.op != spv::FAdd && in.op != spv::ISub && in.op != spv::FSub) return false;
    const bool sub = in.op == spv::ISub || in.op == spv::FSub;
    double c = 0;
    if (constant(in.w[3], c)) {
      phi = in.w[2];
      step = sub ? -c : c;
      return get(phi, spv::Phi) != nullptr;
    }
    if (!sub && constant(in.w[2], c)) {
      phi = in.w[3];
      step = c;
      return get(phi, spv::Phi) != nullptr;
    }
    return false;
  };
  auto bounded = [&](std::uint32_t header, std::uint32_t merge) {
    // The exit test: the header's conditional branch to the merge block, or that of the block the
    // header branches to (glslang's `for` puts the test in its own block).
    const Instruction* br = nullptr;
    std::uint32_t at = header;
    for (int hop = 0; hop < 2 && terminator.count(at); ++hop) {
      const auto& t = ins[terminator[at]];
      if (t.op == spv::BranchConditional && t.w.size() >= 3 && (t.w[1] == merge || t.w[2] == merge)) {
        br = &t;
        break;
      }
      if (t.op != spv::Branch) break;
      at = t.w[0];
    }
    if (!br) return false;
    auto it = def.find(br->w[0]);
    if (it == def.end()) return false;
    const auto& cmp = ins[it->second];
    if (cmp.op < spv::IEqual || cmp.op > spv::FUnordGreaterThanEqual || cmp.w.size() < 4) return false;
    double limit = 0;
    std::uint32_t var = 0;
    if (constant(cmp.w[3], limit))
      var = cmp.w[2];
    else if (constant(cmp.w[2], limit))
      var = cmp.w[3];
    else
      return false;
    std::uint32_t phi_id = var;
    double step = 0;
    if (!get(phi_id, spv::Phi) && !stepped(var, phi_id, step)) return false;
    const Instruction* phi = get(phi_id, spv::Phi);
    double start = 0, inc = 0;
    bool have_start = false, have_inc = false;
    for (std::size_t k = 2; k + 1 < phi->w.size(); k += 2) {
      std::uint32_t back = 0;
      double c = 0;
      if (constant(phi->w[k], c)) {
        start = c;
        have_start = true;
      } else if (stepped(phi->w[k], back, c) && back == phi_id) {
        inc = c;
        have_inc = true;
      } else
        return false;
    }
    if (!have_start || !have_inc || std::abs(inc) < 1) return false;
    // A counter stepping away from its bound (i < 1000; --i), or stepping over it where the test is an
    // equality (i != 1000 from 0 by 3), runs until its type overflows, if ever: not bounded here.
    if ((limit - start) * inc < 0) return false;
    const bool equality = cmp.op == spv::IEqual || cmp.op == spv::INotEqual ||
                          (cmp.op >= spv::FOrdEqual && cmp.op <= spv::FUnordNotEqual);
    if (equality && std::fmod(limit - start, inc) != 0) return false;
    // Iterations: |limit - start| / |step|, one more for <= (+1 kept as margin for either).
    return std::abs(limit - start) / std::abs(inc) + 1.0 <= 65535.0;
  };
  int count = 0;
  for (const auto& [header, merge] : loops) count += bounded(header, merge) ? 0 : 1;
  return count;
}

struct Kernel::Impl {
  Device* device = nullptr;
  std::shared_ptr<Pipeline> pipeline;
  int n_uniforms = 0;
  std::vector<std::pair<std::string, std::string>> included;
};

Kernel::Kernel(const KernelSpec& spec) : Kernel(spec, "", "") {}

Kernel::Kernel(const KernelSpec& spec, const std::string& custom_wrapper, const std::string& signature,
               const std::vector<SpirvResource>& allowed)
    : impl_(std::make_shared<Impl>()) {
  validate_spec(spec);
  const int index = choose_device(spec.device);
  Device& d = device(index);
  impl_->device = &d;
  impl_->n_uniforms = spec.n_uniforms;

  const std::string wrapper =
      custom_wrapper.empty() ? wrapper_source(spec.language, spec.entry, spec.source_name) : custom_wrapper;
  const std::string entry_point = spec.language == "hlsl" ? "glintlab_main" : "main";
  // The cache key is the preprocessed text (the user's code with its #includes and defines expanded),
  // so an edited included file is a new kernel.
  const std::string text = preprocess(spec, wrapper, &impl_->included, signature);
  std::ostringstream key;
  key << spec.language << '|' << spec.entry << '|' << spec.n_uniforms << '|' << fnv1a(text) << '|' << text.size();
  std::lock_guard<std::mutex> lock(d.mutex);
  if (auto it = d.pipelines.find(key.str()); it != d.pipelines.end()) {
    impl_->pipeline = it->second;
    return;
  }
  auto pl = std::make_shared<Pipeline>();
  pl->spirv = compile_spirv(spec, wrapper, entry_point, signature);
  // Before the driver sees it: a resource the pipeline layout lacks (descriptor set 1) crashes lavapipe.
  require_resources(pl->spirv, allowed.empty() ? wrapper_resources() : allowed, spec.source_name,
                    "only the arguments of " +
                        (signature.empty() ? expected_signature(spec.language, spec.entry) : signature) +
                        " (glintlab's own buffers at set 0, bindings 0-3, and its push constant); pass data "
                        "through the uniforms or as constants and defines");
  pl->unbounded_loops = shader::unbounded_loops(pl->spirv);

  VkShaderModuleCreateInfo module{};
  module.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  module.codeSize = pl->spirv.size() * sizeof(std::uint32_t);
  module.pCode = pl->spirv.data();
  check(vkCreateShaderModule(d.dev, &module, nullptr, &pl->module), "vkCreateShaderModule");
  VkDescriptorSetLayoutBinding bindings[4]{};
  for (std::uint32_t i = 0; i < 4; ++i) {
    bindings[i].binding = i;
    bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo set{};
  set.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set.bindingCount = 4;
  set.pBindings = bindings;
  check(vkCreateDescriptorSetLayout(d.dev, &set, nullptr, &pl->set_layout), "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push)};
  VkPipelineLayoutCreateInfo layout{};
  layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout.setLayoutCount = 1;
  layout.pSetLayouts = &pl->set_layout;
  layout.pushConstantRangeCount = 1;
  layout.pPushConstantRanges = &range;
  check(vkCreatePipelineLayout(d.dev, &layout, nullptr, &pl->layout), "vkCreatePipelineLayout");
  VkComputePipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = pl->module;
  info.stage.pName = entry_point.c_str();
  info.layout = pl->layout;
  check(vkCreateComputePipelines(d.dev, VK_NULL_HANDLE, 1, &info, nullptr, &pl->pipeline), "vkCreateComputePipelines");
  d.pipelines[key.str()] = pl;
  impl_->pipeline = std::move(pl);
}

Kernel::~Kernel() = default;

const std::string& Kernel::device_name() const { return impl_->device->name; }
const std::string& Kernel::device_type() const { return impl_->device->type; }
int Kernel::n_uniforms() const { return impl_->n_uniforms; }
const std::vector<std::uint32_t>& Kernel::spirv() const { return impl_->pipeline->spirv; }
const std::vector<std::pair<std::string, std::string>>& Kernel::included_files() const { return impl_->included; }
int Kernel::unbounded_loops() const { return impl_->pipeline->unbounded_loops; }

void Kernel::run(const double* n, std::size_t n_size, const double* p, std::size_t p_size, const double* u,
                 std::size_t count, float* out, double timeout_s) const {
  if (count == 0) return;
  if (!(timeout_s > 0) || !std::isfinite(timeout_s))
    glintlab::throw_invalid("", "timeout", std::to_string(timeout_s), "seconds > 0");
  glintlab::check_length("shader", "n", n_size, count);
  glintlab::check_length("shader", "p", p_size, count);
  Device& d = *impl_->device;
  const Pipeline& pl = *impl_->pipeline;
  const std::size_t k = static_cast<std::size_t>(impl_->n_uniforms);
  const auto timeout_ns = static_cast<std::uint64_t>(std::min(timeout_s, 1e9) * 1e9);
  std::lock_guard<std::mutex> lock(d.mutex);
  wait_for_retired(d, timeout_s);

  const std::size_t chunk = std::min(count, kChunkRows);
  auto job = std::make_unique<Job>(d);
  job->make_buffer(0, (n_size == 1 ? 1 : chunk) * sizeof(float), false);
  job->make_buffer(1, (p_size == 1 ? 1 : chunk) * sizeof(float), false);
  job->make_buffer(2, chunk * 4 * sizeof(float), false);
  job->make_buffer(3, chunk * sizeof(float), true);

  const VkDescriptorSet set = job->bind(pl.set_layout);

  auto* nb = static_cast<float*>(job->buffers[0].mapped);
  auto* pb = static_cast<float*>(job->buffers[1].mapped);
  auto* ub = static_cast<float*>(job->buffers[2].mapped);
  const auto* kb = static_cast<const float*>(job->buffers[3].mapped);
  for (std::size_t base = 0; base < count; base += chunk) {
    const std::size_t rows = std::min(chunk, count - base);
    const auto srows = static_cast<std::ptrdiff_t>(rows);
    if (n_size == 1) nb[0] = static_cast<float>(n[0]);
    if (p_size == 1) pb[0] = static_cast<float>(p[0]);
#pragma omp parallel for schedule(static) if (rows > 65536)
    for (std::ptrdiff_t si = 0; si < srows; ++si) {
      const auto i = static_cast<std::size_t>(si);
      if (n_size != 1) nb[i] = static_cast<float>(n[base + i]);
      if (p_size != 1) pb[i] = static_cast<float>(p[base + i]);
      const double* row = u + (base + i) * k;
      for (std::size_t j = 0; j < 4; ++j) ub[4 * i + j] = j < k ? uniform_to_float(row[j]) : 0.0f;
    }
    const Push push{static_cast<std::uint32_t>(rows), n_size == 1 ? 0u : 1u, p_size == 1 ? 0u : 1u, 0u};
    check(vkResetCommandBuffer(job->command, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(job->command, &begin), "vkBeginCommandBuffer");
    vkCmdBindPipeline(job->command, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipeline);
    vkCmdBindDescriptorSets(job->command, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout, 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(job->command, pl.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &push);
    vkCmdDispatch(job->command, static_cast<std::uint32_t>((rows + kGroupSize - 1) / kGroupSize), 1, 1);
    VkMemoryBarrier barrier{};  // the shader's writes, visible to the host after the fence
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(job->command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier,
                         0, nullptr, 0, nullptr);
    check(vkEndCommandBuffer(job->command), "vkEndCommandBuffer");
    check(vkResetFences(d.dev, 1, &job->fence), "vkResetFences");
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &job->command;
    check(vkQueueSubmit(d.queue, 1, &submit, job->fence), "vkQueueSubmit");
    const VkResult r = vkWaitForFences(d.dev, 1, &job->fence, VK_TRUE, timeout_ns);
    if (r == VK_TIMEOUT) {
      // The device still uses the buffers: they are freed by a later call once the fence signals.
      d.retired.push_back(std::move(job));
      std::ostringstream msg;
      msg << "shader kernel ran longer than timeout = " << timeout_s << " s on '" << d.name << "' (rows " << base
          << " .. " << base + rows << "); its buffers are released when the device finishes";
      throw ShaderTimeout(msg.str());
    }
    check(r, "vkWaitForFences");
    std::memcpy(out + base, kb, rows * sizeof(float));
  }
}

// Method shaders' rows (glintlab/validation/method_shader.hpp): the same pipeline layout, one input
// buffer of in_stride words per row and one output buffer of out_stride floats per row.
void Kernel::run_rows(const float* in, std::size_t in_stride, std::size_t count, float* out, std::size_t out_stride,
                      double timeout_s) const {
  if (count == 0) return;
  if (!(timeout_s > 0) || !std::isfinite(timeout_s))
    glintlab::throw_invalid("", "timeout", std::to_string(timeout_s), "seconds > 0");
  if (in_stride == 0 || out_stride == 0) glintlab::throw_invalid_message("run_rows: strides must be > 0");
  Device& d = *impl_->device;
  const Pipeline& pl = *impl_->pipeline;
  std::lock_guard<std::mutex> lock(d.mutex);
  wait_for_retired(d, timeout_s);
  const std::size_t chunk = std::min(count, kChunkRows / 4);
  auto job = std::make_unique<Job>(d);
  job->make_buffer(0, chunk * in_stride * sizeof(float), false);
  job->make_buffer(1, 4 * sizeof(float), false);
  job->make_buffer(2, 4 * sizeof(float), false);
  job->make_buffer(3, chunk * out_stride * sizeof(float), true);
  const VkDescriptorSet set = job->bind(pl.set_layout);
  auto* ib = static_cast<float*>(job->buffers[0].mapped);
  const auto* ob = static_cast<const float*>(job->buffers[3].mapped);
  const auto timeout_ns = static_cast<std::uint64_t>(std::min(timeout_s, 1e9) * 1e9);
  for (std::size_t base = 0; base < count; base += chunk) {
    const std::size_t rows = std::min(chunk, count - base);
    std::memcpy(ib, in + base * in_stride, rows * in_stride * sizeof(float));
    const Push push{static_cast<std::uint32_t>(rows), static_cast<std::uint32_t>(in_stride),
                    static_cast<std::uint32_t>(out_stride), 0u};
    check(vkResetCommandBuffer(job->command, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(job->command, &begin), "vkBeginCommandBuffer");
    vkCmdBindPipeline(job->command, VK_PIPELINE_BIND_POINT_COMPUTE, pl.pipeline);
    vkCmdBindDescriptorSets(job->command, VK_PIPELINE_BIND_POINT_COMPUTE, pl.layout, 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(job->command, pl.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &push);
    vkCmdDispatch(job->command, static_cast<std::uint32_t>((rows + kGroupSize - 1) / kGroupSize), 1, 1);
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(job->command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier,
                         0, nullptr, 0, nullptr);
    check(vkEndCommandBuffer(job->command), "vkEndCommandBuffer");
    check(vkResetFences(d.dev, 1, &job->fence), "vkResetFences");
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &job->command;
    check(vkQueueSubmit(d.queue, 1, &submit, job->fence), "vkQueueSubmit");
    const VkResult r = vkWaitForFences(d.dev, 1, &job->fence, VK_TRUE, timeout_ns);
    if (r == VK_TIMEOUT) {
      d.retired.push_back(std::move(job));
      std::ostringstream msg;
      msg << "shader kernel ran longer than timeout = " << timeout_s << " s on '" << d.name << "' (rows " << base
          << " .. " << base + rows << "); its buffers are released when the device finishes";
      throw ShaderTimeout(msg.str());
    }
    check(r, "vkWaitForFences");
    std::memcpy(out + base * out_stride, ob, rows * out_stride * sizeof(float));
  }
}

}  // namespace glintlab::shader
