// The shader runner's Vulkan instance and devices (vulkan_device.hpp): one instance per process, one
// logical device per physical device, created on first use and kept for the process's life, the choice
// of a device by request, and one call's resources (Job) with the retirement of those whose kernel
// passed its timeout.
#include "vulkan_device.hpp"

#include "glintlab/base/errors.hpp"
#include "glintlab/validation/shader.hpp"

#include <algorithm>
#include <cctype>
#include <sstream>
#include <stdexcept>

namespace glintlab::shader {
namespace detail {

std::string vk_error(const char* what, VkResult r) {
  return std::string("Vulkan: ") + what + " failed (VkResult " + std::to_string(static_cast<int>(r)) + ")";
}
void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw std::runtime_error(vk_error(what, r));
}

namespace {

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

}  // namespace

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

// ---------------------------------------------------------------- one call's resources

namespace {

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

}  // namespace

Job::~Job() {
  if (fence) vkDestroyFence(d.dev, fence, nullptr);
  if (command) vkFreeCommandBuffers(d.dev, d.pool, 1, &command);
  if (descriptor_pool) vkDestroyDescriptorPool(d.dev, descriptor_pool, nullptr);
  for (auto& b : buffers) {
    if (b.mapped) vkUnmapMemory(d.dev, b.memory);
    if (b.buffer) vkDestroyBuffer(d.dev, b.buffer, nullptr);
    if (b.memory) vkFreeMemory(d.dev, b.memory, nullptr);
  }
}

Buffer create_host_buffer(const Device& d, VkDeviceSize size, VkBufferUsageFlags usage, bool readback) {
  Buffer b;
  b.size = size;
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = size;
  info.usage = usage;
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
  return b;
}

void Job::make_buffer(int i, VkDeviceSize size, bool readback) {
  buffers[i] = create_host_buffer(d, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, readback);
}

VkDescriptorSet Job::bind(VkDescriptorSetLayout layout, VkDescriptorSetLayout user_layout) {
  std::vector<VkDescriptorPoolSize> sizes{{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 4}};
  if (user)
    for (const auto& e : user->entries) sizes.push_back({e.type, 1});
  VkDescriptorPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pool_info.maxSets = user ? 2 : 1;
  pool_info.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
  pool_info.pPoolSizes = sizes.data();
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
  if (user) write_user_set(*user, user_layout);
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

void Job::write_user_set(const BoundResources& bound, VkDescriptorSetLayout user_layout) {
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = descriptor_pool;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &user_layout;
  check(vkAllocateDescriptorSets(d.dev, &alloc, &user_set), "vkAllocateDescriptorSets");
  const std::size_t n = bound.entries.size();
  std::vector<VkDescriptorImageInfo> images(n);
  std::vector<VkDescriptorBufferInfo> buffers_info(n);
  std::vector<VkWriteDescriptorSet> writes(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& e = bound.entries[i];
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = user_set;
    writes[i].dstBinding = static_cast<std::uint32_t>(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = e.type;
    if (e.type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER || e.type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER) {
      buffers_info[i] = {e.buffer.buffer, 0, VK_WHOLE_SIZE};
      writes[i].pBufferInfo = &buffers_info[i];
    } else {
      images[i] = {e.sampler, e.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
      writes[i].pImageInfo = &images[i];
    }
  }
  vkUpdateDescriptorSets(d.dev, static_cast<std::uint32_t>(n), writes.data(), 0, nullptr);
}

namespace {
void reap(Device& d) {  // with d.mutex held
  std::erase_if(d.retired,
                [&](const std::unique_ptr<Job>& j) { return vkGetFenceStatus(d.dev, j->fence) == VK_SUCCESS; });
}
}  // namespace

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

}  // namespace detail

// ---------------------------------------------------------------- public

std::vector<DeviceInfo> vulkan_devices() {
  std::lock_guard<std::mutex> lock(detail::g_vulkan_mutex);
  detail::Vulkan& v = detail::vulkan();
  std::vector<DeviceInfo> out;
  for (std::size_t i = 0; i < v.physical.size(); ++i)
    out.push_back(detail::describe(static_cast<int>(i), v.physical[i]));
  return out;
}

}  // namespace glintlab::shader
