// RADV null devices as a GPU compiler (glintlab/validation/gpu_cost.hpp; docs/guide/gpu_cost.md).
#include "glintlab/validation/gpu_cost.hpp"

#include <dlfcn.h>
#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <regex>
#include <sstream>
#include <thread>

#include "glintlab/base/errors.hpp"

namespace glintlab::gpu_cost {
namespace {

constexpr const char* kWhere = "gpu_cost";
constexpr const char* kPackage = "Mesa's RADV Vulkan driver (Debian package mesa-vulkan-drivers)";

// The library to open: $GLINTLAB_RADV_LIBRARY when set (tests point it elsewhere), else the loader's
// search path, else the library_path of a radeon ICD manifest.
std::vector<std::string> candidate_libraries() {
  if (const char* env = std::getenv("GLINTLAB_RADV_LIBRARY")) return {env};
  std::vector<std::string> out{"libvulkan_radeon.so"};
  for (const char* dir : {"/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d"}) {
    for (const char* arch : {"x86_64", "aarch64", "i686"}) {
      std::ifstream in(std::string(dir) + "/radeon_icd." + arch + ".json");
      if (!in) continue;
      const std::string text((std::istreambuf_iterator<char>(in)), {});
      std::smatch m;
      if (std::regex_search(text, m, std::regex("\"library_path\"\\s*:\\s*\"([^\"]+)\""))) out.push_back(m[1]);
    }
  }
  return out;
}

struct Driver {
  void* handle = nullptr;
  std::string path;
  std::string error;
  PFN_vkGetInstanceProcAddr gipa = nullptr;
  std::vector<std::string> families;  // the names of architectures() found in the library's bytes
};

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

Driver& driver() {
  static Driver d = [] {
    Driver out;
    std::string tried;
    for (const auto& lib : candidate_libraries()) {
      void* h = dlopen(lib.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!h) {
        tried += (tried.empty() ? "" : "; ") + lib + ": " + dlerror();
        continue;
      }
      using Negotiate = VkResult (*)(std::uint32_t*);
      if (auto negotiate = reinterpret_cast<Negotiate>(dlsym(h, "vk_icdNegotiateLoaderICDInterfaceVersion"))) {
        std::uint32_t version = 5;
        negotiate(&version);
      }
      auto gipa = reinterpret_cast<PFN_vkGetInstanceProcAddr>(dlsym(h, "vk_icdGetInstanceProcAddr"));
      if (!gipa) {
        tried += (tried.empty() ? "" : "; ") + lib + ": no vk_icdGetInstanceProcAddr";
        dlclose(h);
        continue;
      }
      Dl_info info{};
      out.handle = h;
      out.gipa = gipa;
      out.path = dladdr(reinterpret_cast<void*>(gipa), &info) && info.dli_fname ? info.dli_fname : lib;
      // One read of the library (8-9 MB), searched once per family name and then dropped.
      std::ifstream in(out.path, std::ios::binary | std::ios::ate);
      std::string image(static_cast<std::size_t>(std::max<std::streamoff>(in.tellg(), 0)), '\0');
      in.seekg(0);
      in.read(image.data(), static_cast<std::streamsize>(image.size()));
      for (const auto& a : architectures())
        if (image.find(std::string(1, '\0') + upper(a.name) + std::string(1, '\0')) != std::string::npos)
          out.families.push_back(a.name);
      return out;
    }
    out.error = std::string(kPackage) + " is not available (" + tried + ")";
    return out;
  }();
  return d;
}

// RADV matches RADV_FORCE_FAMILY against its family names (ac_get_family_name, upper case in the
// library, compared case-insensitively) and aborts on any other: the name must be there.
bool driver_knows(const std::string& name) {
  const auto& f = driver().families;
  return std::find(f.begin(), f.end(), name) != f.end();
}

std::string known_list() {
  std::string out;
  for (const auto& a : known_architectures()) out += (out.empty() ? "" : ", ") + a;
  return out.empty() ? "(none: RADV is missing)" : out;
}

const Architecture& lookup(const std::string& arch) {
  for (const auto& a : architectures())
    if (a.name == arch) {
      Driver& d = driver();
      if (!d.gipa) throw CompilerMissing(d.error);
      if (!driver_knows(arch))
        throw_unknown_name(kWhere, "architecture (not known to " + d.path + ")", arch, known_list());
      return a;
    }
  throw_unknown_name(kWhere, "architecture", arch, known_list());
}

template <class T>
T vk(VkStructureType type) {  // a Vulkan structure zeroed but for its type
  T x{};
  x.sType = type;
  return x;
}

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS)
    throw std::runtime_error(std::string("gpu_cost: ") + what + " failed (VkResult " + std::to_string(r) + ")");
}

// One null device per architecture, kept for the process's life.
struct NullDevice {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  std::string name, driver;
  std::mutex mutex;  // the device's creation and one compile at a time
  PFN_vkGetDeviceProcAddr gdpa = nullptr;
};

class EnvOverride {  // sets a variable for a scope, restoring the previous value (or its absence)
 public:
  EnvOverride(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    setenv(name, value.c_str(), 1);
  }
  ~EnvOverride() {
    if (had_)
      setenv(name_, old_.c_str(), 1);
    else
      unsetenv(name_);
  }
  EnvOverride(const EnvOverride&) = delete;
  EnvOverride& operator=(const EnvOverride&) = delete;

 private:
  const char* name_;
  std::string old_;
  bool had_ = false;
};

// The instance and physical device of `arch`'s null device, made once under one process-wide lock with
// RADV_FORCE_FAMILY set for that moment only (both read the environment; about a millisecond).
NullDevice& null_instance(const Architecture& arch) {
  static std::mutex creation;
  static std::map<std::string, std::unique_ptr<NullDevice>> devices;
  std::lock_guard<std::mutex> lock(creation);
  auto& slot = devices[arch.name];
  if (slot) return *slot;
  auto nd = std::make_unique<NullDevice>();
  const Driver& d = driver();
  {
    // RADV reads both when the instance is created and enumerates: the family, and no shader cache
    // (the statistics come from a fresh compile, and nothing is written under the user's home).
    EnvOverride family("RADV_FORCE_FAMILY", arch.name);
    EnvOverride debug("RADV_DEBUG", "nocache");
    auto create = reinterpret_cast<PFN_vkCreateInstance>(d.gipa(VK_NULL_HANDLE, "vkCreateInstance"));
    auto app = vk<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
    app.pApplicationName = "glintlab gpu_cost";
    app.apiVersion = VK_API_VERSION_1_2;
    auto ci = vk<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
    ci.pApplicationInfo = &app;
    check(create(&ci, nullptr, &nd->instance), "vkCreateInstance (RADV null device)");
    auto enumerate =
        reinterpret_cast<PFN_vkEnumeratePhysicalDevices>(d.gipa(nd->instance, "vkEnumeratePhysicalDevices"));
    std::uint32_t n = 0;
    check(enumerate(nd->instance, &n, nullptr), "vkEnumeratePhysicalDevices");
    if (n == 0) throw CompilerMissing("gpu_cost: RADV created no null device for '" + arch.name + "'");
    std::vector<VkPhysicalDevice> phys(n);
    check(enumerate(nd->instance, &n, phys.data()), "vkEnumeratePhysicalDevices");
    nd->physical = phys[0];
  }
  auto props2 =
      reinterpret_cast<PFN_vkGetPhysicalDeviceProperties2>(d.gipa(nd->instance, "vkGetPhysicalDeviceProperties2"));
  auto dp = vk<VkPhysicalDeviceDriverProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES);
  auto p = vk<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
  p.pNext = &dp;
  props2(nd->physical, &p);
  nd->name = p.properties.deviceName;
  nd->driver = std::string(dp.driverName) + " " + dp.driverInfo;
  slot = std::move(nd);
  return *slot;
}

// With nd.mutex held: the logical device, made on first use. Apart from the instance's lock because on
// RDNA2 and later RADV compiles its ray-tracing build shaders here (about 0.2 s of CPU per device), and
// several architectures' devices can then be made at once (compile_stats_many).
void open_device(NullDevice& nd) {
  if (nd.device) return;
  const Driver& d = driver();
  float priority = 1.0f;
  auto q = vk<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  q.queueCount = 1;
  q.pQueuePriorities = &priority;
  const char* extensions[] = {"VK_KHR_pipeline_executable_properties", "VK_EXT_subgroup_size_control"};
  auto sizes = vk<VkPhysicalDeviceSubgroupSizeControlFeaturesEXT>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_SIZE_CONTROL_FEATURES_EXT);
  sizes.subgroupSizeControl = VK_TRUE;
  auto exec = vk<VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR);
  exec.pipelineExecutableInfo = VK_TRUE;
  exec.pNext = &sizes;
  auto dci = vk<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
  dci.pNext = &exec;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &q;
  dci.enabledExtensionCount = 2;
  dci.ppEnabledExtensionNames = extensions;
  auto create_device = reinterpret_cast<PFN_vkCreateDevice>(d.gipa(nd.instance, "vkCreateDevice"));
  check(create_device(nd.physical, &dci, nullptr, &nd.device), "vkCreateDevice (RADV null device)");
  nd.gdpa = reinterpret_cast<PFN_vkGetDeviceProcAddr>(d.gipa(nd.instance, "vkGetDeviceProcAddr"));
}

// The compute entry point's name (OpEntryPoint GLCompute), refusing anything else.
std::string compute_entry(const std::vector<std::uint32_t>& w) {
  if (w.size() < 5 || w[0] != 0x07230203u) throw_invalid_message("gpu_cost: spirv: not a SPIR-V module (magic number)");
  for (std::size_t i = 5; i < w.size();) {
    const std::uint32_t count = w[i] >> 16, op = w[i] & 0xFFFFu;
    if (count == 0 || i + count > w.size()) break;
    if (op == 15 && count >= 4 && w[i + 1] == 5) {  // OpEntryPoint GLCompute %id "name"
      const char* s = reinterpret_cast<const char*>(&w[i + 3]);
      return std::string(s, strnlen(s, (count - 3) * 4));
    }
    i += count;
  }
  throw_invalid_message("gpu_cost: spirv: no GLCompute entry point (a compute kernel glintlab runs)");
}

template <class F>
F device_fn(NullDevice& nd, const char* name) {
  auto f = reinterpret_cast<F>(nd.gdpa(nd.device, name));
  if (!f) throw std::runtime_error(std::string("gpu_cost: the driver lacks ") + name);
  return f;
}

struct PipelineObjects {  // destroyed in reverse order of creation
  NullDevice& nd;
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  ~PipelineObjects() {
    if (pipeline) device_fn<PFN_vkDestroyPipeline>(nd, "vkDestroyPipeline")(nd.device, pipeline, nullptr);
    if (layout) device_fn<PFN_vkDestroyPipelineLayout>(nd, "vkDestroyPipelineLayout")(nd.device, layout, nullptr);
    if (set) device_fn<PFN_vkDestroyDescriptorSetLayout>(nd, "vkDestroyDescriptorSetLayout")(nd.device, set, nullptr);
    if (module) device_fn<PFN_vkDestroyShaderModule>(nd, "vkDestroyShaderModule")(nd.device, module, nullptr);
  }
};

void create_pipeline(PipelineObjects& o, const std::vector<std::uint32_t>& spirv, const std::string& entry,
                     std::uint32_t wave, bool representations) {
  NullDevice& nd = o.nd;
  auto sm = vk<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  sm.codeSize = spirv.size() * sizeof(std::uint32_t);
  sm.pCode = spirv.data();
  check(device_fn<PFN_vkCreateShaderModule>(nd, "vkCreateShaderModule")(nd.device, &sm, nullptr, &o.module),
        "vkCreateShaderModule");
  // The runner's layout (shader_runner.cpp): four storage buffers at set 0 and a push constant.
  VkDescriptorSetLayoutBinding bindings[4]{};
  for (std::uint32_t i = 0; i < 4; ++i) {
    bindings[i].binding = i;
    bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  auto set = vk<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  set.bindingCount = 4;
  set.pBindings = bindings;
  check(device_fn<PFN_vkCreateDescriptorSetLayout>(nd, "vkCreateDescriptorSetLayout")(nd.device, &set, nullptr, &o.set),
        "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 128};
  auto pl = vk<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  pl.setLayoutCount = 1;
  pl.pSetLayouts = &o.set;
  pl.pushConstantRangeCount = 1;
  pl.pPushConstantRanges = &range;
  check(device_fn<PFN_vkCreatePipelineLayout>(nd, "vkCreatePipelineLayout")(nd.device, &pl, nullptr, &o.layout),
        "vkCreatePipelineLayout");
  auto size = vk<VkPipelineShaderStageRequiredSubgroupSizeCreateInfoEXT>(
      VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_REQUIRED_SUBGROUP_SIZE_CREATE_INFO_EXT);
  size.requiredSubgroupSize = wave;
  auto cp = vk<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  cp.flags = VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR |
             (representations ? VK_PIPELINE_CREATE_CAPTURE_INTERNAL_REPRESENTATIONS_BIT_KHR : 0);
  cp.stage = vk<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  cp.stage.pNext = &size;
  cp.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  cp.stage.module = o.module;
  cp.stage.pName = entry.c_str();
  cp.layout = o.layout;
  check(device_fn<PFN_vkCreateComputePipelines>(nd, "vkCreateComputePipelines")(nd.device, VK_NULL_HANDLE, 1, &cp,
                                                                                nullptr, &o.pipeline),
        "vkCreateComputePipelines");
}

void read_executable(NullDevice& nd, VkPipeline pipeline, bool representations, PipelineStats& out) {
  auto pi = vk<VkPipelineInfoKHR>(VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR);
  pi.pipeline = pipeline;
  std::uint32_t n = 0;
  auto props = device_fn<PFN_vkGetPipelineExecutablePropertiesKHR>(nd, "vkGetPipelineExecutablePropertiesKHR");
  check(props(nd.device, &pi, &n, nullptr), "vkGetPipelineExecutablePropertiesKHR");
  if (n == 0) throw std::runtime_error("gpu_cost: the driver reported no executable for the pipeline");
  std::vector<VkPipelineExecutablePropertiesKHR> ep(
      n, vk<VkPipelineExecutablePropertiesKHR>(VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR));
  check(props(nd.device, &pi, &n, ep.data()), "vkGetPipelineExecutablePropertiesKHR");
  out.subgroup_size = static_cast<int>(ep[0].subgroupSize);
  auto ei = vk<VkPipelineExecutableInfoKHR>(VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR);
  ei.pipeline = pipeline;
  ei.executableIndex = 0;
  auto stats = device_fn<PFN_vkGetPipelineExecutableStatisticsKHR>(nd, "vkGetPipelineExecutableStatisticsKHR");
  std::uint32_t ns = 0;
  check(stats(nd.device, &ei, &ns, nullptr), "vkGetPipelineExecutableStatisticsKHR");
  std::vector<VkPipelineExecutableStatisticKHR> st(
      ns, vk<VkPipelineExecutableStatisticKHR>(VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR));
  check(stats(nd.device, &ei, &ns, st.data()), "vkGetPipelineExecutableStatisticsKHR");
  for (const auto& s : st) {
    double v = 0;
    switch (s.format) {
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR: v = s.value.b32 ? 1 : 0; break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR: v = static_cast<double>(s.value.i64); break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR: v = static_cast<double>(s.value.u64); break;
      default: v = s.value.f64;
    }
    out.statistics.emplace_back(s.name, v);
  }
  if (!representations) return;
  auto irs = device_fn<PFN_vkGetPipelineExecutableInternalRepresentationsKHR>(
      nd, "vkGetPipelineExecutableInternalRepresentationsKHR");
  std::uint32_t nr = 0;
  check(irs(nd.device, &ei, &nr, nullptr), "vkGetPipelineExecutableInternalRepresentationsKHR");
  std::vector<VkPipelineExecutableInternalRepresentationKHR> ir(
      nr, vk<VkPipelineExecutableInternalRepresentationKHR>(
              VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INTERNAL_REPRESENTATION_KHR));
  check(irs(nd.device, &ei, &nr, ir.data()), "vkGetPipelineExecutableInternalRepresentationsKHR");
  std::vector<std::string> text(nr);
  for (std::uint32_t i = 0; i < nr; ++i) {
    text[i].assign(ir[i].dataSize, '\0');
    ir[i].pData = text[i].data();
  }
  check(irs(nd.device, &ei, &nr, ir.data()), "vkGetPipelineExecutableInternalRepresentationsKHR");
  for (std::uint32_t i = 0; i < nr; ++i) {
    std::string t = text[i].substr(0, strnlen(text[i].data(), text[i].size()));
    out.representations.emplace_back(ir[i].name, std::move(t));
  }
}

}  // namespace

const std::vector<Architecture>& architectures() {
  // Boost clocks and compute units of each family's largest desktop part (the integrated gfx1036:
  // the Ryzen 7000 desktop processors' graphics).
  static const std::vector<Architecture> table{
      {"polaris10", "GCN4", "Radeon RX 480", 64, 36, 4, 1266.0},
      {"vega10", "GCN5", "Radeon RX Vega 64", 64, 64, 4, 1546.0},
      {"navi10", "RDNA1", "Radeon RX 5700 XT", 32, 40, 2, 1905.0},
      {"navi21", "RDNA2", "Radeon RX 6900 XT", 32, 80, 2, 2250.0},
      {"gfx1036", "RDNA2", "Radeon Graphics (Ryzen 7000, 2 CU)", 32, 2, 2, 2200.0},
      {"gfx1100", "RDNA3", "Radeon RX 7900 XTX", 32, 96, 2, 2500.0},
  };
  return table;
}

std::vector<std::string> known_architectures() {
  std::vector<std::string> out;
  if (!driver().gipa) return out;
  for (const auto& a : architectures())
    if (driver_knows(a.name)) out.push_back(a.name);
  return out;
}

DriverStatus driver_status() {
  const Driver& d = driver();
  return {d.path, d.gipa ? "" : d.error};
}

PipelineStats compile_stats(const std::vector<std::uint32_t>& spirv, const std::string& arch, bool representations) {
  const Architecture& a = lookup(arch);
  const std::string entry = compute_entry(spirv);
  NullDevice& nd = null_instance(a);
  std::lock_guard<std::mutex> lock(nd.mutex);
  open_device(nd);
  PipelineStats out;
  out.arch = a.name;
  out.device_name = nd.name;
  out.driver = nd.driver;
  PipelineObjects objects{nd};
  create_pipeline(objects, spirv, entry, static_cast<std::uint32_t>(a.wave_size), representations);
  read_executable(nd, objects.pipeline, representations, out);
  return out;
}

void open_devices(const std::vector<std::string>& archs, bool devices) {
  std::vector<NullDevice*> nds;
  for (const auto& a : archs) nds.push_back(&null_instance(lookup(a)));
  if (!devices) return;
  std::vector<std::exception_ptr> errors(nds.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < nds.size(); ++i)
    threads.emplace_back([&, i] {
      try {
        std::lock_guard<std::mutex> lock(nds[i]->mutex);
        open_device(*nds[i]);
      } catch (...) { errors[i] = std::current_exception(); }
    });
  for (auto& t : threads) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

std::vector<PipelineStats> compile_stats_many(const std::vector<std::vector<std::uint32_t>>& spirvs,
                                              const std::vector<std::string>& archs, bool representations) {
  // Everything that can be refused, and every environment change (the instances), before any thread.
  for (const auto& s : spirvs) compute_entry(s);
  open_devices(archs, false);
  const std::size_t n = spirvs.size();
  std::vector<PipelineStats> out(archs.size() * n);
  std::vector<std::exception_ptr> errors(archs.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < archs.size(); ++i)
    threads.emplace_back([&, i] {
      try {
        for (std::size_t j = 0; j < n; ++j) out[i * n + j] = compile_stats(spirvs[j], archs[i], representations);
      } catch (...) { errors[i] = std::current_exception(); }
    });
  for (auto& t : threads) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return out;
}

}  // namespace glintlab::gpu_cost
