// The user's own read-only resources on the device (glintlab/validation/shader.hpp, "the user's own
// read-only resources"): the descriptor set layout of what the code declares (set 1), and the images,
// samplers and buffers holding the data bound to it by name, uploaded once per bind and shared by every
// call of the kernel (a timed-out call's retired job keeps them alive).
#include "glintlab/base/errors.hpp"
#include "vulkan_device.hpp"

#include <algorithm>
#include <cstring>
#include <set>

namespace glintlab::shader::detail {
namespace {

VkDescriptorType descriptor_type(const DeclaredResource& r) {
  if (r.kind == "texture") return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  if (r.kind == "image") return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
  if (r.kind == "sampler") return VK_DESCRIPTOR_TYPE_SAMPLER;
  if (r.kind == "storage buffer") return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
}

std::uint32_t find_memory(const Device& d, std::uint32_t bits, VkMemoryPropertyFlags need) {
  for (std::uint32_t i = 0; i < d.memory.memoryTypeCount; ++i)
    if ((bits & (1u << i)) && (d.memory.memoryTypes[i].propertyFlags & need) == need) return i;
  throw std::runtime_error("Vulkan: device '" + d.name + "' has no memory type for a resource");
}

// A host-visible, mapped buffer holding `words` (zero-padded to at least 16 bytes).
Buffer host_buffer(Device& d, const std::vector<std::uint32_t>& words, VkBufferUsageFlags usage) {
  Buffer b = create_host_buffer(d, std::max<VkDeviceSize>(16, words.size() * sizeof(std::uint32_t)), usage, false);
  std::memset(b.mapped, 0, static_cast<std::size_t>(b.size));
  if (!words.empty()) std::memcpy(b.mapped, words.data(), words.size() * sizeof(std::uint32_t));
  return b;
}

void free_buffer(Device& d, Buffer& b) {
  if (b.mapped) vkUnmapMemory(d.dev, b.memory);
  if (b.buffer) vkDestroyBuffer(d.dev, b.buffer, nullptr);
  if (b.memory) vkFreeMemory(d.dev, b.memory, nullptr);
  b = Buffer{};
}

VkFormat texture_format(const std::string& scalar, int channels) {
  const int c = channels == 3 ? 4 : channels;
  if (scalar == "float")
    return c == 1 ? VK_FORMAT_R32_SFLOAT : c == 2 ? VK_FORMAT_R32G32_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
  if (scalar == "int")
    return c == 1 ? VK_FORMAT_R32_SINT : c == 2 ? VK_FORMAT_R32G32_SINT : VK_FORMAT_R32G32B32A32_SINT;
  return c == 1 ? VK_FORMAT_R32_UINT : c == 2 ? VK_FORMAT_R32G32_UINT : VK_FORMAT_R32G32B32A32_UINT;
}

[[noreturn]] void refuse(const std::string& source_name, const DeclaredResource& r, const std::string& why) {
  glintlab::throw_invalid_message("shader " + source_name + ": resource '" + r.name + "' (" + r.kind + "): " + why);
}

VkSampler make_sampler(Device& d, const ResourceData& data, float max_lod) {
  VkSamplerCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  const bool linear = data.filter == "linear";
  info.magFilter = info.minFilter = linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  info.mipmapMode = linear ? VK_SAMPLER_MIPMAP_MODE_LINEAR : VK_SAMPLER_MIPMAP_MODE_NEAREST;
  const VkSamplerAddressMode mode = data.address == "clamp"    ? VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE
                                    : data.address == "mirror" ? VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT
                                                               : VK_SAMPLER_ADDRESS_MODE_REPEAT;
  info.addressModeU = info.addressModeV = info.addressModeW = mode;
  info.minLod = 0.0f;
  info.maxLod = max_lod;
  VkSampler s = VK_NULL_HANDLE;
  check(vkCreateSampler(d.dev, &info, nullptr, &s), "vkCreateSampler");
  return s;
}

// Runs `record` in a one-time command buffer on d's queue and waits for it.
template <class Record>
void submit_now(Device& d, Record record) {
  VkCommandBufferAllocateInfo cmd{};
  cmd.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  cmd.commandPool = d.pool;
  cmd.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cmd.commandBufferCount = 1;
  VkCommandBuffer command = VK_NULL_HANDLE;
  check(vkAllocateCommandBuffers(d.dev, &cmd, &command), "vkAllocateCommandBuffers");
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(command, &begin), "vkBeginCommandBuffer");
  record(command);
  check(vkEndCommandBuffer(command), "vkEndCommandBuffer");
  VkFenceCreateInfo fence_info{};
  fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  VkFence fence = VK_NULL_HANDLE;
  check(vkCreateFence(d.dev, &fence_info, nullptr, &fence), "vkCreateFence");
  VkSubmitInfo submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &command;
  VkResult r = vkQueueSubmit(d.queue, 1, &submit, fence);
  if (r == VK_SUCCESS) r = vkWaitForFences(d.dev, 1, &fence, VK_TRUE, UINT64_MAX);
  vkDestroyFence(d.dev, fence, nullptr);
  vkFreeCommandBuffers(d.dev, d.pool, 1, &command);
  check(r, "uploading a texture");
}

void transition(VkCommandBuffer c, VkImage image, std::uint32_t levels, std::uint32_t layers, VkImageLayout from,
                VkImageLayout to, VkAccessFlags src, VkAccessFlags dst, VkPipelineStageFlags src_stage,
                VkPipelineStageFlags dst_stage) {
  VkImageMemoryBarrier b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcAccessMask = src;
  b.dstAccessMask = dst;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, levels, 0, layers};
  vkCmdPipelineBarrier(c, src_stage, dst_stage, 0, 0, nullptr, 0, nullptr, 1, &b);
}

// A texture's image, its view and its memory, with every mip level uploaded.
void make_texture(Device& d, const DeclaredResource& r, const ResourceData& data, BoundResources::Entry& e,
                  const std::string& source_name) {
  const std::uint32_t w = data.extent[0], h = data.extent[1], depth = data.extent[2], layers = data.extent[3];
  const auto levels = static_cast<std::uint32_t>(data.levels.size());
  const int stored = data.channels == 3 ? 4 : data.channels;
  if (levels == 0 || data.channels < 1 || data.channels > 4)
    refuse(source_name, r, "no texels, or not 1 to 4 channels");
  if (r.channels && r.channels != data.channels)
    refuse(source_name, r,
           "declared with " + std::to_string(r.channels) + " channel(s), given " + std::to_string(data.channels));
  const VkFormat format = texture_format(r.scalar, data.channels);
  VkFormatProperties props{};
  vkGetPhysicalDeviceFormatProperties(d.phys, format, &props);
  if (!(props.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT))
    refuse(source_name, r, "the device '" + d.name + "' cannot sample this format");
  if (data.filter == "linear" && !(props.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT))
    refuse(source_name, r, "filter 'linear' is not supported for this format on '" + d.name + "' (use 'nearest')");
  VkImageCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
  info.imageType = r.dims == 1 ? VK_IMAGE_TYPE_1D : r.dims == 2 ? VK_IMAGE_TYPE_2D : VK_IMAGE_TYPE_3D;
  info.format = format;
  info.extent = {w, h, depth};
  info.mipLevels = levels;
  info.arrayLayers = layers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  check(vkCreateImage(d.dev, &info, nullptr, &e.image), "vkCreateImage");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(d.dev, e.image, &req);
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = find_memory(d, req.memoryTypeBits, 0);
  check(vkAllocateMemory(d.dev, &alloc, nullptr, &e.memory), "vkAllocateMemory");
  check(vkBindImageMemory(d.dev, e.image, e.memory, 0), "vkBindImageMemory");
  // Every level into one staging buffer, each level's texels tightly packed (layer, depth, row, column).
  std::vector<std::uint32_t> staged;
  std::vector<VkBufferImageCopy> copies;
  for (std::uint32_t k = 0; k < levels; ++k) {
    const std::uint32_t lw = std::max(1u, w >> k), lh = std::max(1u, h >> k), ld = std::max(1u, depth >> k);
    const std::size_t expected = std::size_t{lw} * lh * ld * layers * static_cast<std::size_t>(stored);
    if (data.levels[k].size() != expected)
      refuse(source_name, r,
             "mip level " + std::to_string(k) + " holds " + std::to_string(data.levels[k].size()) +
                 " words, expected " + std::to_string(expected));
    VkBufferImageCopy c{};
    c.bufferOffset = staged.size() * sizeof(std::uint32_t);
    c.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, k, 0, layers};
    c.imageExtent = {lw, lh, ld};
    copies.push_back(c);
    staged.insert(staged.end(), data.levels[k].begin(), data.levels[k].end());
  }
  Buffer staging = host_buffer(d, staged, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  submit_now(d, [&](VkCommandBuffer c) {
    transition(c, e.image, levels, layers, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
               VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    vkCmdCopyBufferToImage(c, staging.buffer, e.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           static_cast<std::uint32_t>(copies.size()), copies.data());
    transition(c, e.image, levels, layers, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT,
               VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
  });
  free_buffer(d, staging);
  VkImageViewCreateInfo view{};
  view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
  view.image = e.image;
  view.viewType = r.dims == 1   ? (r.arrayed ? VK_IMAGE_VIEW_TYPE_1D_ARRAY : VK_IMAGE_VIEW_TYPE_1D)
                  : r.dims == 2 ? (r.arrayed ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D)
                                : VK_IMAGE_VIEW_TYPE_3D;
  view.format = format;
  view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, levels, 0, layers};
  check(vkCreateImageView(d.dev, &view, nullptr, &e.view), "vkCreateImageView");
  if (r.kind == "texture") e.sampler = make_sampler(d, data, static_cast<float>(levels - 1));
}

}  // namespace

BoundResources::~BoundResources() {
  for (auto& e : entries) {
    if (e.sampler) vkDestroySampler(d.dev, e.sampler, nullptr);
    if (e.view) vkDestroyImageView(d.dev, e.view, nullptr);
    if (e.image) vkDestroyImage(d.dev, e.image, nullptr);
    if (e.memory) vkFreeMemory(d.dev, e.memory, nullptr);
    free_buffer(d, e.buffer);
  }
}

VkDescriptorSetLayout user_set_layout(Device& d, const std::vector<DeclaredResource>& user) {
  std::vector<VkDescriptorSetLayoutBinding> bindings(user.size());
  for (std::size_t i = 0; i < user.size(); ++i) {
    bindings[i].binding = static_cast<std::uint32_t>(user[i].binding);
    bindings[i].descriptorType = descriptor_type(user[i]);
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo set{};
  set.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set.bindingCount = static_cast<std::uint32_t>(bindings.size());
  set.pBindings = bindings.data();
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  check(vkCreateDescriptorSetLayout(d.dev, &set, nullptr, &layout), "vkCreateDescriptorSetLayout");
  return layout;
}

std::shared_ptr<BoundResources> bind_user_resources(Device& d, const std::vector<DeclaredResource>& user,
                                                    const std::vector<ResourceData>& data,
                                                    const std::string& source_name) {
  std::set<std::string> declared;
  for (const auto& r : user) declared.insert(r.name);
  for (const auto& g : data)
    if (!declared.count(g.name))
      glintlab::throw_invalid_message("shader " + source_name + ": resource '" + g.name +
                                      "' is given but the shader does not declare it");
  auto bound = std::make_shared<BoundResources>(d);
  for (const auto& r : user) {
    const auto it = std::find_if(data.begin(), data.end(), [&](const ResourceData& g) { return g.name == r.name; });
    if (it == data.end()) refuse(source_name, r, "declared but no data is bound to it");
    BoundResources::Entry& e = bound->entries.emplace_back();
    e.type = descriptor_type(r);
    if (r.kind == "texture" || r.kind == "image") {
      make_texture(d, r, *it, e, source_name);
    } else if (r.kind == "sampler") {
      e.sampler = make_sampler(d, *it, VK_LOD_CLAMP_NONE);
    } else {
      if (it->levels.size() != 1) refuse(source_name, r, "a buffer takes one array of data");
      const std::size_t bytes = it->levels[0].size() * sizeof(std::uint32_t);
      if (r.kind == "uniform buffer" && bytes < r.size)
        refuse(source_name, r, std::to_string(bytes) + " bytes given, the block holds " + std::to_string(r.size));
      if (r.kind == "storage buffer" && (bytes == 0 || (r.size && bytes % r.size)))
        refuse(source_name, r,
               std::to_string(bytes) + " bytes given: not a whole number of its " + std::to_string(r.size) +
                   "-byte elements");
      e.buffer = host_buffer(
          d, it->levels[0],
          r.kind == "uniform buffer" ? VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT : VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    }
  }
  return bound;
}

}  // namespace glintlab::shader::detail
