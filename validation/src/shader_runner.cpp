// The Vulkan compute runner behind every shader kind (glintlab/validation/shader.hpp): a Kernel is a
// wrapper kernel (shader_wrapper.cpp) around the user's code, compiled (shader_compile.cpp), its
// resources checked (spirv_inspect.cpp) and built into a pipeline on a device (vulkan_device.cpp);
// its calls go through one submit path, chunk by chunk: record, submit, wait, and retire on timeout.
#include "glintlab/validation/shader.hpp"

#include "glintlab/base/errors.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <sstream>

#include "dispatch_timing.hpp"
#include "glintlab/base/float32.hpp"
#include "vulkan_device.hpp"

namespace glintlab::shader {
namespace {

using detail::check;
using detail::Device;
using detail::Job;
using detail::Pipeline;

constexpr std::size_t kChunkRows = std::size_t{1} << 20;  // rows per submission (16384 groups)

// The push constant of every wrapper: the rows of this submission, then three words of the kind's
// (a law's n and p strides, the row kinds' input and output strides).
struct Push {
  std::uint32_t count, a, b, pad;
};

std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// The layout every wrapper kernel shares: storage buffers at set 0, bindings 0-3, and the push constant.
void make_pipeline(Device& d, Pipeline& pl, const std::string& entry_point) {
  VkShaderModuleCreateInfo module{};
  module.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  module.codeSize = pl.spirv.size() * sizeof(std::uint32_t);
  module.pCode = pl.spirv.data();
  check(vkCreateShaderModule(d.dev, &module, nullptr, &pl.module), "vkCreateShaderModule");
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
  check(vkCreateDescriptorSetLayout(d.dev, &set, nullptr, &pl.set_layout), "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push)};
  VkDescriptorSetLayout sets[2] = {pl.set_layout, VK_NULL_HANDLE};
  if (!pl.user.empty()) sets[1] = pl.user_layout = detail::user_set_layout(d, pl.user);
  VkPipelineLayoutCreateInfo layout{};
  layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout.setLayoutCount = pl.user.empty() ? 1 : 2;
  layout.pSetLayouts = sets;
  layout.pushConstantRangeCount = 1;
  layout.pPushConstantRanges = &range;
  check(vkCreatePipelineLayout(d.dev, &layout, nullptr, &pl.layout), "vkCreatePipelineLayout");
  VkComputePipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = pl.module;
  info.stage.pName = entry_point.c_str();
  info.layout = pl.layout;
  check(vkCreateComputePipelines(d.dev, VK_NULL_HANDLE, 1, &info, nullptr, &pl.pipeline), "vkCreateComputePipelines");
}

void check_timeout(double timeout_s) {
  if (!(timeout_s > 0) || !std::isfinite(timeout_s))
    glintlab::throw_invalid("", "timeout", std::to_string(timeout_s), "seconds > 0");
}

// One call of a kernel: the device held (its mutex) from construction to destruction, the call's
// buffers (bindings 0-3, host-visible, binding 3 read back), and the one path every chunk takes.
class Submission {
 public:
  Submission(Device& d, const Pipeline& pl, const std::array<VkDeviceSize, 4>& bytes, double timeout_s,
             std::shared_ptr<detail::BoundResources> user)
      : d_(d), pl_(pl), lock_(d.mutex), job_(std::make_unique<Job>(d)), timeout_s_(timeout_s) {
    detail::wait_for_retired(d, timeout_s);
    for (int i = 0; i < 4; ++i) job_->make_buffer(i, bytes[static_cast<std::size_t>(i)], i == 3);
    job_->user = std::move(user);
    set_ = job_->bind(pl.set_layout, pl.user_layout);
  }
  float* buffer(int binding) const { return static_cast<float*>(job_->buffers[binding].mapped); }

  // Records and submits rows [base, base + push.count) and waits for them. A kernel that passes the
  // timeout leaves its job to the device's retired list (freed once its fence signals) and throws
  // ShaderTimeout.
  void dispatch(const Push& push, std::size_t base) {
    VkCommandBuffer command = job_->command;
    check(vkResetCommandBuffer(command, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(command, &begin), "vkBeginCommandBuffer");
    vkCmdBindPipeline(command, VK_PIPELINE_BIND_POINT_COMPUTE, pl_.pipeline);
    const VkDescriptorSet sets[2] = {set_, job_->user_set};
    vkCmdBindDescriptorSets(command, VK_PIPELINE_BIND_POINT_COMPUTE, pl_.layout, 0, job_->user ? 2 : 1, sets, 0,
                            nullptr);
    vkCmdPushConstants(command, pl_.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &push);
    const bool timed = detail::timestamp_before(d_, command);  // DispatchTiming on this thread
    vkCmdDispatch(command, (push.count + kWorkGroupSize - 1) / kWorkGroupSize, 1, 1);
    if (timed) detail::timestamp_after(d_, command);
    VkMemoryBarrier barrier{};  // the shader's writes, visible to the host after the fence
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0,
                         nullptr, 0, nullptr);
    check(vkEndCommandBuffer(command), "vkEndCommandBuffer");
    check(vkResetFences(d_.dev, 1, &job_->fence), "vkResetFences");
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &command;
    check(vkQueueSubmit(d_.queue, 1, &submit, job_->fence), "vkQueueSubmit");
    const auto timeout_ns = static_cast<std::uint64_t>(std::min(timeout_s_, 1e9) * 1e9);
    const VkResult r = vkWaitForFences(d_.dev, 1, &job_->fence, VK_TRUE, timeout_ns);
    if (r == VK_TIMEOUT) {
      // The device still uses the buffers: they are freed by a later call once the fence signals.
      d_.retired.push_back(std::move(job_));
      std::ostringstream msg;
      msg << "shader kernel ran longer than timeout = " << timeout_s_ << " s on '" << d_.name << "' (rows " << base
          << " .. " << base + push.count << "); its buffers are released when the device finishes";
      throw ShaderTimeout(msg.str());
    }
    check(r, "vkWaitForFences");
    if (timed) detail::timestamp_read(d_);
  }

 private:
  Device& d_;
  const Pipeline& pl_;
  std::lock_guard<std::mutex> lock_;
  std::unique_ptr<Job> job_;
  double timeout_s_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

}  // namespace

struct Kernel::Impl {
  Device* device = nullptr;
  std::shared_ptr<Pipeline> pipeline;
  int n_uniforms = 0;
  std::vector<std::pair<std::string, std::string>> included;
  std::string source_name;
  std::shared_ptr<detail::BoundResources> bound;  // the data of the declared resources, once bound

  // The bound resources a call uses; throws naming the first declared resource when none are bound.
  std::shared_ptr<detail::BoundResources> resources() const {
    if (!pipeline->user.empty() && !bound) {
      const auto& r = pipeline->user.front();
      glintlab::throw_invalid_message("shader " + source_name + ": resource '" + r.name + "' (" + r.kind +
                                      ") is declared but no data is bound to it (bind_resources)");
    }
    return bound;
  }
};

Kernel::Kernel(const KernelSpec& spec) : Kernel(spec, law_wrapper(spec.entry)) {}

Kernel::Kernel(const KernelSpec& spec, const WrapperDeclaration& kind) : impl_(std::make_shared<Impl>()) {
  validate_spec(spec);
  Device& d = detail::device(detail::choose_device(spec.device));
  impl_->device = &d;
  impl_->n_uniforms = spec.n_uniforms;
  impl_->source_name = spec.source_name;
  const std::string entry_point = spec.language == "hlsl" ? "glintlab_main" : "main";
  const std::string wrapper = generate_wrapper(kind, spec.language, spec.source_name);
  const std::string signature = wrapper_signature(kind, spec.language);
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
  // Before the driver sees it: the user's resources move to set 1 (a resource the pipeline layout lacks
  // crashes lavapipe), and one the runner cannot bind is refused by name.
  pl->user = remap_user_resources(pl->spirv, wrapper_resources(kind));
  for (const auto& r : pl->user)
    if (!r.refused.empty())
      glintlab::throw_invalid_message("shader " + spec.source_name + ": resource '" + r.name + "' (" + r.kind +
                                      ") is not bound by glintlab: " + r.refused + "; expected the arguments of " +
                                      signature +
                                      " and read-only textures, samplers, storage buffers and uniform blocks");
  pl->unbounded_loops = shader::unbounded_loops(pl->spirv);
  make_pipeline(d, *pl, entry_point);
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
const std::vector<DeclaredResource>& Kernel::declared_resources() const { return impl_->pipeline->user; }

void Kernel::bind_resources(const std::vector<ResourceData>& data) {
  Device& d = *impl_->device;
  std::lock_guard<std::mutex> lock(d.mutex);
  impl_->bound = detail::bind_user_resources(d, impl_->pipeline->user, data, impl_->source_name);
}

void Kernel::run(const double* n, std::size_t n_size, const double* p, std::size_t p_size, const double* u,
                 std::size_t count, float* out, double timeout_s) const {
  if (count == 0) return;
  check_timeout(timeout_s);
  glintlab::check_length("shader", "n", n_size, count);
  glintlab::check_length("shader", "p", p_size, count);
  const std::size_t k = static_cast<std::size_t>(impl_->n_uniforms);
  const std::size_t chunk = std::min(count, kChunkRows);
  Submission call(*impl_->device, *impl_->pipeline,
                  {(n_size == 1 ? 1 : chunk) * sizeof(float), (p_size == 1 ? 1 : chunk) * sizeof(float),
                   chunk * 4 * sizeof(float), chunk * sizeof(float)},
                  timeout_s, impl_->resources());
  float* nb = call.buffer(0);
  float* pb = call.buffer(1);
  float* ub = call.buffer(2);
  const float* kb = call.buffer(3);
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
    call.dispatch({static_cast<std::uint32_t>(rows), n_size == 1 ? 0u : 1u, p_size == 1 ? 0u : 1u, 0u}, base);
    std::memcpy(out + base, kb, rows * sizeof(float));
  }
}

// The row kinds' path (method shaders, shader samplers): binding 0 holds in_stride words per row,
// binding 3 receives out_stride floats per row; bindings 1 and 2 are one-word placeholders.
void Kernel::run_rows(const float* in, std::size_t in_stride, std::size_t count, float* out, std::size_t out_stride,
                      double timeout_s, std::uint32_t lanes) const {
  if (count == 0) return;
  check_timeout(timeout_s);
  if (in_stride == 0 || out_stride == 0 || lanes == 0 || lanes > 4)
    glintlab::throw_invalid_message("run_rows: strides must be > 0, lanes 1 to 4");
  const std::size_t chunk = std::min(count, kChunkRows / 4);
  Submission call(
      *impl_->device, *impl_->pipeline,
      {chunk * in_stride * sizeof(float), 4 * sizeof(float), 4 * sizeof(float), chunk * out_stride * sizeof(float)},
      timeout_s, impl_->resources());
  float* ib = call.buffer(0);
  const float* ob = call.buffer(3);
  for (std::size_t base = 0; base < count; base += chunk) {
    const std::size_t rows = std::min(chunk, count - base);
    std::memcpy(ib, in + base * in_stride, rows * in_stride * sizeof(float));
    call.dispatch({static_cast<std::uint32_t>(rows) * lanes, static_cast<std::uint32_t>(in_stride),
                   static_cast<std::uint32_t>(out_stride), 0u},
                  base);
    std::memcpy(out + base * out_stride, ob, rows * out_stride * sizeof(float));
  }
}

}  // namespace glintlab::shader
