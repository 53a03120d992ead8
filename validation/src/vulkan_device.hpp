// The shader runner's Vulkan side, private to validation/src: the process's instance and its logical
// devices (vulkan_device.cpp), the pipelines cached per device, and one call's resources (a Job: four
// storage buffers, a descriptor set, a command buffer and a fence) that the submit path
// (shader_runner.cpp) records, submits and waits on.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "glintlab/validation/shader.hpp"

namespace glintlab::shader::detail {

constexpr const char* kInstallHint =
    "install a Vulkan driver: on Debian `apt-get install mesa-vulkan-drivers libvulkan1` (lavapipe, "
    "Vulkan on the CPU), or your GPU vendor's driver";

std::string vk_error(const char* what, VkResult r);
// Throws std::runtime_error naming the call when r is not VK_SUCCESS.
void check(VkResult r, const char* what);

// A compiled kernel's pipeline: its layout (four storage buffers at set 0, bindings 0-3, and a push
// constant of four words) is the same for every kind of kernel; the user's own resources, when the code
// declares any, are set 1 (kUserSet).
struct Pipeline {
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkDescriptorSetLayout user_layout = VK_NULL_HANDLE;  // set 1, when `user` is not empty
  std::vector<DeclaredResource> user;
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

// The index of the device `request` names ("auto", "gpu", "cpu", an index or part of a name); throws
// NoVulkanDevice or std::invalid_argument naming the devices there are.
int choose_device(const std::string& request);
// The logical device of physical device `index`, created on first use and kept for the process's life.
Device& device(int index);

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
  VkDeviceSize size = 0;
};

// A host-visible, coherent buffer of `size` bytes for `usage`, bound and mapped (`readback`: cached memory
// where the device has it); the one place buffers are made, for the jobs' buffers and the bound resources.
Buffer create_host_buffer(const Device& d, VkDeviceSize size, VkBufferUsageFlags usage, bool readback);

// The Vulkan objects holding the data bound to a kernel's declared resources (Kernel::bind_resources),
// one entry per declared resource in binding order; shared by the jobs that use them, so a retired job
// keeps them alive until its fence signals.
struct BoundResources {
  Device& d;
  struct Entry {
    VkDescriptorType type = VK_DESCRIPTOR_TYPE_SAMPLER;
    VkImage image = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    VkSampler sampler = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;  // the image's
    Buffer buffer;                           // storage and uniform buffers
  };
  std::vector<Entry> entries;
  explicit BoundResources(Device& device) : d(device) {}
  ~BoundResources();
  BoundResources(const BoundResources&) = delete;
  BoundResources& operator=(const BoundResources&) = delete;
};

// The descriptor set layout of the declared resources (set 1).
VkDescriptorSetLayout user_set_layout(Device& d, const std::vector<DeclaredResource>& user);
// The data bound to `user` on device d (with d.mutex held: uploads use the queue). Throws
// std::invalid_argument naming a resource left unbound, one not declared, or data that does not fit.
std::shared_ptr<BoundResources> bind_user_resources(Device& d, const std::vector<DeclaredResource>& user,
                                                    const std::vector<ResourceData>& data,
                                                    const std::string& source_name);

// One call's resources. Freed when the call returns, or, when its kernel passed its timeout, retired to
// the device and freed once its fence signals.
struct Job {
  Device& d;
  Buffer buffers[4];                     // bindings 0-3
  std::shared_ptr<BoundResources> user;  // set 1, when the kernel declares resources
  VkDescriptorSet user_set = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool = VK_NULL_HANDLE;
  VkCommandBuffer command = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;

  explicit Job(Device& device) : d(device) {}
  ~Job();
  Job(const Job&) = delete;
  Job& operator=(const Job&) = delete;
  // Buffer i, host-visible and mapped (`readback`: cached memory where the device has it).
  void make_buffer(int i, VkDeviceSize size, bool readback);
  // Binds the four buffers as storage buffers 0-3 of a descriptor set of `layout` (and `user`'s
  // resources to a set of `user_layout`, into user_set) and allocates the command buffer and fence of
  // this job. Returns the set.
  VkDescriptorSet bind(VkDescriptorSetLayout layout, VkDescriptorSetLayout user_layout = VK_NULL_HANDLE);
  void write_user_set(const BoundResources& bound, VkDescriptorSetLayout user_layout);
};

// With d.mutex held, before a submission: an earlier kernel that passed its timeout and still runs
// would delay this call's kernel, and a timeout then would blame this one. Waits for the earlier one
// within this call's timeout, else throws ShaderDeviceBusy.
void wait_for_retired(Device& d, double timeout_s);

}  // namespace glintlab::shader::detail
