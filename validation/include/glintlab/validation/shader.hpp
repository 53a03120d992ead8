// Counting laws written as shader functions (HLSL or GLSL), compiled to SPIR-V by shaderc and run
// by a Vulkan compute pipeline: the shader source itself, not a re-implementation, is what glintlab
// then measures (docs/guide/shaders.md).
//
// The contract: the user writes one function
//     float count(float n, float p, float4 u)      (HLSL; GLSL: float count(float n, float p, vec4 u))
// and glintlab wraps it in its own compute kernel (buffers, bindings, dispatch). n and p arrive as
// float(n), float(p); the uniforms by uniform_to_float (glintlab/base/float32.hpp); unused ones are 0.
//
// Runner policy: one Vulkan instance per process and one logical device per physical device, kept
// for the process's life; pipelines cached by a hash of (device, language, entry, source, included
// files, defines, uniforms). Calls on one device are serialized by a mutex (safe from many threads:
// they queue). Buffers are allocated per call and freed before it returns; a call that passes its
// timeout throws ShaderTimeout and its buffers are retired, freed once the device finishes the work.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace glintlab::shader {

// A kernel that ran past its timeout (Python: TimeoutError).
class ShaderTimeout : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A call that could not start within its timeout because the device was still running an earlier
// kernel that had passed its own timeout (Python: glintlab's ShaderDeviceBusy, a TimeoutError): this
// call's kernel never ran.
class ShaderDeviceBusy : public ShaderTimeout {
 public:
  using ShaderTimeout::ShaderTimeout;
};

// No usable Vulkan instance or device (Python: RuntimeError), naming the package to install.
class NoVulkanDevice : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct DeviceInfo {
  int index = 0;            // in vkEnumeratePhysicalDevices order
  std::string name;         // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string type;         // "discrete_gpu", "integrated_gpu", "virtual_gpu", "cpu", "other"
  std::string api_version;  // "1.3.230"
  std::string driver;       // driver name and info when the device reports them
};

// Every Vulkan device the loader sees (empty when there is none; never throws for that).
std::vector<DeviceInfo> vulkan_devices();

struct KernelSpec {
  std::string source;       // the user's code
  std::string source_name;  // its file path (messages, #include "x" relative to it), or "<string>"
  std::string entry = "count";
  std::string language = "hlsl";                             // "hlsl" or "glsl"
  int n_uniforms = 2;                                        // 0 .. 4
  std::vector<std::pair<std::string, std::string>> defines;  // -D NAME=VALUE
  std::vector<std::string> include_dirs;                     // searched after the source's folder
  // "auto" (a GPU when there is one, else the CPU device), "gpu", "cpu", or a device index ("0") or
  // a substring of a device name.
  std::string device = "auto";
  // When not empty, #include "x" is served from these (path as resolved, content) only, never from
  // the disk: the files a kernel read when it was first compiled (Kernel::included_files), so that a
  // pickled law compiles the same code anywhere, whatever happened to the files since.
  std::vector<std::pair<std::string, std::string>> include_files;
  // Compile for Vulkan 1.1 (SPIR-V 1.3): the fragment mode's quad operations (its dFdx, dFdy) need it.
  bool vulkan_1_1 = false;
};

// A resource a SPIR-V module declares: a variable in the UniformConstant (samplers, images),
// Uniform (uniform or storage blocks), StorageBuffer or PushConstant storage class.
struct SpirvResource {
  std::string name;  // the variable's name, else its block's type name, else "%<id>"
  std::string kind;  // "storage buffer", "uniform buffer", "push constant", "sampler or image"
  int set = -1;      // DescriptorSet decoration (-1: none)
  int binding = -1;  // Binding decoration (-1: none)
};

// ---------------------------------------------------------------- the user's own read-only resources
// Textures, samplers, storage buffers and uniform blocks (cbuffers, HLSL's $Global) the user's code
// declares, beside glintlab's own buffers. Whatever set and binding the code gives them (or none:
// shaderc binds them automatically), the runner moves them to descriptor set 1, bindings 0, 1, ... in
// declaration order, so they never collide with the wrapper's set 0, and binds the data given for
// each by name (Kernel::bind_resources). docs/guide/shaders.md#textures-buffers-and-uniforms.
constexpr int kUserSet = 1;

// A member of a uniform block (a cbuffer's or a GLSL uniform block's), as the SPIR-V lays it out.
struct BlockMember {
  std::string name;
  std::uint32_t offset = 0;  // bytes from the block's start
  std::string scalar;        // "float", "int", "uint" (32-bit); "" for a type the runner cannot fill
  int components = 1;        // 1 (scalar) to 4 (vector)
  int count = 0;             // array length; 0 for a member that is not an array
  std::uint32_t array_stride = 0;
};

// A resource the user's code declares, reflected from the SPIR-V.
struct DeclaredResource {
  std::string name;  // the variable's name (GLSL blocks: the instance's name, else the block type's)
  // "texture" (an image with its sampler: GLSL sampler2D), "image" (an image without sampler: HLSL
  // Texture2D), "sampler" (HLSL SamplerState, GLSL sampler), "storage buffer", "uniform buffer"
  std::string kind;
  int binding = 0;         // at set kUserSet, after remapping
  int dims = 0;            // textures and images: 1, 2 or 3
  bool arrayed = false;    // a texture array (Texture2DArray, sampler2DArray)
  std::string scalar;      // textures: the sampled type ("float", "int", "uint"); buffers: the element's
  int channels = 0;        // textures: from a declared format (0: any of 1 to 4); storage buffers: 32-bit
                           // words per element
  std::uint32_t size = 0;  // storage buffers: bytes per element (ArrayStride); uniform buffers: the block's bytes
  std::vector<BlockMember> members;  // uniform buffers
  std::string refused;               // why the runner cannot bind it ("" when it can)
};

// The data bound to one declared resource. Textures: levels[k] holds mip level k's texels, layer by
// layer, then depth, row, column, channel (32-bit words: float32 bits or integers); extent is level
// 0's (width, height, depth, layers), 1 where unused. Storage and uniform buffers: levels[0] is the
// bytes as 32-bit words. Textures with their sampler, and samplers: the sampler state.
struct ResourceData {
  std::string name;
  std::vector<std::vector<std::uint32_t>> levels;
  std::uint32_t extent[4] = {1, 1, 1, 1};
  int channels = 1;               // textures: 1, 2 or 4 (3-channel data arrives padded to 4)
  std::string filter = "linear";  // "nearest" or "linear" (also between mip levels)
  std::string address = "wrap";   // "wrap", "clamp" or "mirror"
};

// ---------------------------------------------------------------- wrapper kernels, one generator
// Every kind of shader (a counting law, a method shader, a shader sampler) is the user's function(s)
// inside a compute kernel of glintlab's. One generator writes that kernel, in HLSL or GLSL, from the
// kind's declaration: the push constant, the storage buffers, the values the entry reads (each a
// field of a type at a word of the input row), the call and its stores. The resources the SPIR-V may
// declare and the signature compile errors name come from the same declaration. The texts of a
// declaration are written in GLSL's spelling; HLSL gets them with its own type names and bit casts
// (vec2 -> float2, ..., uvec2 -> uint2, uintBitsToFloat -> asfloat), word for word; `$0` and `$1`
// stand for the entry functions' names.

constexpr unsigned kWorkGroupSize = 64;  // threads per work group, in every wrapper and in the dispatch

// A storage buffer of the kernel, at descriptor set 0.
struct WrapperBuffer {
  int binding = 0;
  std::string variable;  // HLSL: the variable; GLSL: the block's array ("glintlab_in")
  std::string block;     // GLSL: the block's type name ("GlintlabIn")
  std::string element;   // GLSL spelling: "float", "vec4", "uint"
  bool written = false;  // the kernel writes it (RWStructuredBuffer, writeonly); else reads it
};

// A value the kernel reads for the entry. From the input row (binding 0, uint words at row i *
// in_stride): `word` is its first word, floats (float, vec2..vec4) are float32 bits, integers (uint,
// uvec2) the words themselves. Or, where `read` is given, that expression (a buffer of its own).
struct WrapperField {
  WrapperField(std::string name_, std::string type_, int word_)  // from the row
      : name(std::move(name_)), type(std::move(type_)), word(word_) {}
  WrapperField(std::string name_, std::string type_, std::string read_)  // its own expression
      : name(std::move(name_)), type(std::move(type_)), read(std::move(read_)) {}
  std::string name;
  std::string type;  // GLSL spelling: "float", "vec2", "vec3", "vec4", "uint", "uvec2"
  int word = -1;
  std::string read;  // GLSL spelling; "" to read the row's words
};

struct WrapperDeclaration {
  std::string header;                  // glintlab's include before the user's code: "glintlab_method" reads
                                       // glintlab_method_hlsl.h / glintlab_method_glsl.h ("": none)
  std::vector<std::string> push;       // the push constant's three words after `count`
  std::vector<WrapperBuffer> buffers;  // by binding
  std::string record;                  // "GlintInput g": the fields are this struct's members ("": locals)
  std::vector<WrapperField> fields;
  std::string helpers;               // functions before the kernel's main
  std::string call;                  // main's last lines: the entry's call and the stores
  std::string signature;             // the entry's expected signature(s), for compile errors
  std::vector<std::string> entries;  // the names $0, $1 stand for
};

// The kernel's source in `language` ("hlsl" or "glsl"); `include_name` is the user's file.
std::string generate_wrapper(const WrapperDeclaration& kind, const std::string& language,
                             const std::string& include_name);
// The declaration's signature in `language`.
std::string wrapper_signature(const WrapperDeclaration& kind, const std::string& language);
// The resources the declaration's kernel binds (both languages' names): all the SPIR-V may declare.
std::vector<SpirvResource> wrapper_resources(const WrapperDeclaration& kind);
// A counting law's declaration: float entry(float n, float p, vec4 u) over n, p, u buffers.
WrapperDeclaration law_wrapper(const std::string& entry);

class Kernel {
 public:
  // A counting law's kernel (law_wrapper(spec.entry)). Compiles (or finds in the cache) and builds the
  // pipeline. Throws std::invalid_argument with the compiler's messages (file:line) for code that does
  // not compile or lacks the expected entry.
  explicit Kernel(const KernelSpec& spec);
  // A kernel of another kind (method shaders, shader samplers): its wrapper generated from `kind`
  // (same bindings 0..3 and push constant layout); the SPIR-V may declare no resource but the
  // declaration's (require_resources).
  Kernel(const KernelSpec& spec, const WrapperDeclaration& kind);
  ~Kernel();
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;

  const std::string& device_name() const;
  const std::string& device_type() const;
  int n_uniforms() const;
  // The SPIR-V words the pipeline runs (for inspection and tests).
  const std::vector<std::uint32_t>& spirv() const;
  // Every file #include'd while compiling, as (path as resolved, content), in the order first read.
  const std::vector<std::pair<std::string, std::string>>& included_files() const;
  // Loops of the SPIR-V whose trip count is not a known constant of at most 65535 (loop_report).
  int unbounded_loops() const;
  // The resources the user's code declares (at set kUserSet), in binding order.
  const std::vector<DeclaredResource>& declared_resources() const;
  // Binds data to every declared resource, by name (replacing earlier data). Throws
  // std::invalid_argument naming a declared resource left unbound, a resource given that the code does
  // not declare, or data that does not fit its declaration. A kernel that declares resources runs
  // only once they are bound.
  void bind_resources(const std::vector<ResourceData>& data);

  // out[i] = entry(float(n[i]), float(p[i]), u_f32(row i)); n and p have size 1 (broadcast) or
  // count; u holds count rows of n_uniforms() uniforms. timeout_s bounds each submission.
  void run(const double* n, std::size_t n_size, const double* p, std::size_t p_size, const double* u, std::size_t count,
           float* out, double timeout_s) const;

  // Raw rows, for kernels with their own wrapper: binding 0 holds count rows of in_stride 32-bit
  // words, binding 3 receives count rows of out_stride floats; the push constants are (rows,
  // in_stride, out_stride, 0); bindings 1 and 2 are one-word placeholders.
  // `lanes` invocations serve each row (the fragment mode's quads: 4); the push constant's count is then
  // rows * lanes.
  void run_rows(const float* in, std::size_t in_stride, std::size_t count, float* out, std::size_t out_stride,
                double timeout_s, std::uint32_t lanes = 1) const;

  struct Impl;

 private:
  std::shared_ptr<Impl> impl_;
};

// The wrapper kernel glintlab puts around the user's counting function (for the docs and for tests):
// generate_wrapper(law_wrapper(entry), language, include_name).
std::string wrapper_source(const std::string& language, const std::string& entry, const std::string& include_name);

// ---------------------------------------------------------------- the compile path, piece by piece
// Kernel's constructor is these steps in order; another contract (another wrapper, other bindings)
// reuses them.

// Checks the parts of a spec every contract shares (language, entry, n_uniforms, define names,
// source name); throws std::invalid_argument naming the parameter.
void validate_spec(const KernelSpec& spec);

// The wrapper preprocessed (the user's code, its #includes and the defines expanded): the cache key.
// `included`, when given, receives every included file (path as resolved, content). Throws
// std::invalid_argument with the compiler's messages; an #include nested deeper than
// kMaxIncludeDepth (a cycle: a.h -> b.h -> a.h) or more than kMaxIncludes in all is refused naming
// the chain, within milliseconds (glslang itself would expand a cycle until memory runs out).
constexpr int kMaxIncludeDepth = 32;
constexpr int kMaxIncludes = 4096;
std::string preprocess(const KernelSpec& spec, const std::string& wrapper,
                       std::vector<std::pair<std::string, std::string>>* included = nullptr,
                       const std::string& signature = "");

// The wrapper compiled to SPIR-V (entry point `entry_point`). Throws as preprocess does (`signature`:
// the entry's expected signature, for the message when the wrapper's call does not match).
std::vector<std::uint32_t> compile_spirv(const KernelSpec& spec, const std::string& wrapper,
                                         const std::string& entry_point, const std::string& signature = "");

std::vector<SpirvResource> spirv_resources(const std::vector<std::uint32_t>& spirv);

// The resources of `spirv` that are not in `allowed` (the wrapper's own), reflected, and `spirv`
// rewritten so that they sit at set kUserSet, bindings 0, 1, ... in that order. A resource the runner
// cannot bind (a storage image, a texel buffer, an array of textures, a push constant) comes back with
// its `refused` reason.
std::vector<DeclaredResource> remap_user_resources(std::vector<std::uint32_t>& spirv,
                                                   const std::vector<SpirvResource>& allowed);

// Throws std::invalid_argument naming the first resource of `spirv` that is not in `allowed` (same
// name, kind, set and binding): a resource the runner does not bind reads garbage or crashes the
// driver (a descriptor set the pipeline layout lacks).
void require_resources(const std::vector<std::uint32_t>& spirv, const std::vector<SpirvResource>& allowed,
                       const std::string& source_name, const std::string& contract);

// Loops (OpLoopMerge) whose trip count is not shown to be at most 65535 by the pattern
// "phi from a constant, stepped by a constant, compared with a constant": lavapipe (llvmpipe) stops
// every loop after 65535 iterations, so such a loop may compute something else there than on a GPU.
int unbounded_loops(const std::vector<std::uint32_t>& spirv);

}  // namespace glintlab::shader
