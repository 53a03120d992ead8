// The shader runner's SPIR-V inspection (glintlab/validation/shader.hpp): the resources a module
// declares, checked against those its wrapper binds before the driver sees the module, and the loops
// whose trip count is not shown to stay within lavapipe's cap. A few opcodes read by number; no
// SPIR-V library.
#include "glintlab/base/errors.hpp"
#include "glintlab/validation/shader.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <tuple>

namespace glintlab::shader {
namespace {
// The few opcodes and enumerants read here, by their numbers in the SPIR-V specification (section 3).
namespace spv {
constexpr std::uint32_t kMagic = 0x07230203;
enum Op : std::uint32_t {
  Name = 5,
  MemberName = 6,
  TypeInt = 21,
  TypeFloat = 22,
  TypeVector = 23,
  TypeMatrix = 24,
  TypeImage = 25,
  TypeSampler = 26,
  TypeSampledImage = 27,
  TypeArray = 28,
  TypeRuntimeArray = 29,
  TypeStruct = 30,
  TypePointer = 32,
  Constant = 43,
  Variable = 59,
  Decorate = 71,
  MemberDecorate = 72,
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
enum Decoration : std::uint32_t {
  Block = 2,
  BufferBlock = 3,
  ArrayStride = 6,
  NonWritable = 24,
  Offset = 35,
  Binding = 33,
  DescriptorSet = 34
};
}  // namespace spv

struct Instruction {
  std::uint32_t op = 0;
  std::vector<std::uint32_t> w;  // the operand words (after the opcode word)
  std::size_t at = 0;            // the opcode word's index in the module
};

std::vector<Instruction> instructions(const std::vector<std::uint32_t>& code) {
  if (code.size() < 5 || code[0] != spv::kMagic) glintlab::throw_invalid_message("not a SPIR-V module");
  std::vector<Instruction> out;
  for (std::size_t i = 5; i < code.size();) {
    const std::uint32_t count = code[i] >> 16;
    if (count == 0 || i + count > code.size()) glintlab::throw_invalid_message("truncated SPIR-V module");
    out.push_back({code[i] & 0xFFFFu,
                   std::vector<std::uint32_t>(code.begin() + static_cast<std::ptrdiff_t>(i) + 1,
                                              code.begin() + static_cast<std::ptrdiff_t>(i + count)),
                   i});
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
    if (r.name.empty()) r.name = std::string(1, '%').append(std::to_string(id));  // (GCC 12 -Wrestrict on "%" + s)
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

namespace {

// The types, names and decorations of a module, enough to describe the resources it declares.
struct Reflection {
  std::map<std::uint32_t, Instruction> types;        // type id -> its OpType* instruction
  std::map<std::uint32_t, std::uint32_t> constants;  // id -> a 32-bit constant's value
  std::map<std::uint32_t, std::string> names;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::string> member_names;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> offsets;
  std::map<std::uint32_t, std::uint32_t> strides;
  std::map<std::uint32_t, bool> block, buffer_block;
  std::map<std::uint32_t, bool> read_only;  // a block whose members are NonWritable (readonly, StructuredBuffer)

  explicit Reflection(const std::vector<Instruction>& ins) {
    for (const auto& in : ins) {
      if (in.op == spv::Name && in.w.size() >= 2) names[in.w[0]] = literal_string(in.w, 1);
      if (in.op == spv::MemberName && in.w.size() >= 3) member_names[{in.w[0], in.w[1]}] = literal_string(in.w, 2);
      if (in.op == spv::Decorate && in.w.size() >= 2) {
        if (in.w[1] == spv::ArrayStride && in.w.size() >= 3) strides[in.w[0]] = in.w[2];
        if (in.w[1] == spv::Block) block[in.w[0]] = true;
        if (in.w[1] == spv::BufferBlock) buffer_block[in.w[0]] = true;
      }
      if (in.op == spv::MemberDecorate && in.w.size() >= 4 && in.w[2] == spv::Offset)
        offsets[{in.w[0], in.w[1]}] = in.w[3];
      if (in.op == spv::MemberDecorate && in.w.size() >= 3 && in.w[2] == spv::NonWritable) read_only[in.w[0]] = true;
      if (in.op >= spv::TypeInt && in.op <= spv::TypePointer && !in.w.empty()) types[in.w[0]] = in;
      if (in.op == spv::Constant && in.w.size() == 3) constants[in.w[1]] = in.w[2];
    }
  }
  const Instruction* type(std::uint32_t id) const {
    auto it = types.find(id);
    return it == types.end() ? nullptr : &it->second;
  }
  // A 32-bit scalar's name ("float", "int", "uint"), else "".
  std::string scalar(std::uint32_t id) const {
    const Instruction* t = type(id);
    if (!t || t->w.size() < 2 || t->w[1] != 32) return "";
    if (t->op == spv::TypeFloat) return "float";
    if (t->op == spv::TypeInt && t->w.size() >= 3) return t->w[2] ? "int" : "uint";
    return "";
  }
  // A scalar or vector: (scalar, components); ("", 0) otherwise.
  std::pair<std::string, int> element(std::uint32_t id) const {
    const Instruction* t = type(id);
    if (t && t->op == spv::TypeVector && t->w.size() >= 3) return {scalar(t->w[1]), static_cast<int>(t->w[2])};
    const std::string s = scalar(id);
    return {s, s.empty() ? 0 : 1};
  }
  void describe_image(const Instruction& image, DeclaredResource& r) const {
    // OpTypeImage: result, sampled type, Dim, depth, arrayed, multisampled, sampled, format.
    const std::uint32_t dim = image.w[2];
    r.scalar = scalar(image.w[1]);
    r.arrayed = image.w[4] != 0;
    r.dims = dim <= 2 ? static_cast<int>(dim) + 1 : 0;
    if (dim == 5)
      r.refused = "a texel buffer (Buffer<T>, samplerBuffer): declare a StructuredBuffer / readonly buffer instead";
    else if (dim > 2)
      r.refused = "a cube, rectangle or subpass image: only 1D, 2D and 3D textures (and their arrays) are bound";
    else if (image.w[5] != 0)
      r.refused = "a multisampled image";
    else if (image.w[6] == 2)
      r.refused = "a storage image (RWTexture, image2D): the resources glintlab binds are read-only";
    else if (r.scalar.empty())
      r.refused = "a texture of a sampled type other than 32-bit float, int or uint";
    // Image formats with their channel counts (SPIR-V's ImageFormat): Rgba32f 1, R32f 3, Rg32f 7, the
    // integer ones alike; others leave the count to the data.
    static const std::map<std::uint32_t, int> kChannels{{1, 4},  {3, 1},  {7, 2},  {21, 4}, {24, 1},
                                                        {25, 2}, {30, 4}, {33, 1}, {35, 2}};
    if (image.w.size() >= 8)
      if (auto it = kChannels.find(image.w[7]); it != kChannels.end()) r.channels = it->second;
  }
  void describe_block(std::uint32_t struct_id, bool storage, DeclaredResource& r) const {
    const Instruction* s = type(struct_id);
    if (!s || s->op != spv::TypeStruct) {
      r.refused = "a block of unknown layout";
      return;
    }
    if (storage) {
      r.kind = "storage buffer";
      if (!read_only.count(struct_id)) {
        r.refused =
            "a writable storage buffer (RWStructuredBuffer, a GLSL buffer without readonly): the resources "
            "glintlab binds are read-only (declare it StructuredBuffer / readonly buffer)";
        return;
      }
      const Instruction* arr = s->w.size() == 2 ? type(s->w[1]) : nullptr;
      if (!arr || arr->op != spv::TypeRuntimeArray) {
        r.refused = "a storage buffer whose only member is not an unsized array (T data[])";
        return;
      }
      r.size = strides.count(arr->w[0]) ? strides.at(arr->w[0]) : 0;
      r.scalar = element(arr->w[1]).first;
      if (r.scalar.empty()) r.scalar = "struct";
      r.channels = static_cast<int>(r.size / 4);
      return;
    }
    r.kind = "uniform buffer";
    for (std::uint32_t m = 1; m < s->w.size(); ++m) {
      BlockMember bm;
      const std::uint32_t index = m - 1;
      bm.name = member_names.count({struct_id, index}) ? member_names.at({struct_id, index}) : "";
      bm.offset = offsets.count({struct_id, index}) ? offsets.at({struct_id, index}) : 0;
      std::uint32_t t = s->w[m];
      const Instruction* ti = type(t);
      if (ti && ti->op == spv::TypeArray && ti->w.size() >= 3) {
        bm.count = constants.count(ti->w[2]) ? static_cast<int>(constants.at(ti->w[2])) : 0;
        bm.array_stride = strides.count(t) ? strides.at(t) : 0;
        t = ti->w[1];
      }
      std::tie(bm.scalar, bm.components) = element(t);
      const std::uint32_t end = bm.offset + (bm.count ? bm.array_stride * static_cast<std::uint32_t>(bm.count)
                                                      : 4u * static_cast<std::uint32_t>(std::max(bm.components, 4)));
      r.size = std::max(r.size, end);
      r.members.push_back(bm);
    }
  }
};

}  // namespace

std::vector<DeclaredResource> remap_user_resources(std::vector<std::uint32_t>& spirv,
                                                   const std::vector<SpirvResource>& allowed) {
  const auto ins = instructions(spirv);
  const Reflection refl(ins);
  const auto all = spirv_resources(spirv);
  std::vector<std::uint32_t> ids;  // the variables of all, in the same order
  for (const auto& in : ins)
    if (in.op == spv::Variable && in.w.size() >= 3 &&
        (in.w[2] == spv::UniformConstant || in.w[2] == spv::Uniform || in.w[2] == spv::PushConstant ||
         in.w[2] == spv::StorageBuffer))
      ids.push_back(in.w[1]);
  std::vector<DeclaredResource> out;
  std::map<std::uint32_t, int> binding_of;  // user variable id -> its new binding
  for (std::size_t k = 0; k < all.size(); ++k) {
    const auto& sr = all[k];
    if (std::any_of(allowed.begin(), allowed.end(), [&](const SpirvResource& a) {
          return a.name == sr.name && a.kind == sr.kind && a.set == sr.set && a.binding == sr.binding;
        }))
      continue;
    DeclaredResource r;
    r.name = sr.name;
    r.binding = static_cast<int>(out.size());
    const Instruction* var = nullptr;
    for (const auto& in : ins)
      if (in.op == spv::Variable && in.w.size() >= 3 && in.w[1] == ids[k]) var = &in;
    const Instruction* ptr = refl.type(var->w[0]);
    const std::uint32_t pointee = ptr && ptr->w.size() >= 3 ? ptr->w[2] : 0;
    const Instruction* t = refl.type(pointee);
    if (var->w[2] == spv::PushConstant) {
      r.kind = "push constant";
      r.refused = "a push constant (glintlab's wrapper owns the push constant): declare a cbuffer / uniform block";
    } else if (var->w[2] == spv::UniformConstant) {
      if (t && t->op == spv::TypeSampledImage) {
        r.kind = "texture";
        const Instruction* image = refl.type(t->w[1]);
        if (image) refl.describe_image(*image, r);
      } else if (t && t->op == spv::TypeImage) {
        r.kind = "image";
        refl.describe_image(*t, r);
      } else if (t && t->op == spv::TypeSampler) {
        r.kind = "sampler";
      } else {
        r.kind = "sampler or image";
        r.refused = "an array of textures or samplers, or an opaque type glintlab does not bind";
      }
    } else {
      const bool storage = var->w[2] == spv::StorageBuffer || refl.buffer_block.count(pointee);
      refl.describe_block(pointee, storage, r);
    }
    binding_of[ids[k]] = r.binding;
    out.push_back(r);
  }
  // Rewrite the user's variables' DescriptorSet and Binding decorations (glslang gives every resource
  // both, with automatic bindings on); a variable lacking one gets it added after the decorations.
  std::map<std::uint32_t, int> have;  // id -> bit 1: set seen, bit 2: binding seen
  std::size_t after_decorations = 0;
  for (const auto& in : ins) {
    if (in.op == spv::Decorate && in.w.size() >= 3 && binding_of.count(in.w[0])) {
      if (in.w[1] == spv::DescriptorSet) {
        spirv[in.at + 3] = static_cast<std::uint32_t>(kUserSet);
        have[in.w[0]] |= 1;
      }
      if (in.w[1] == spv::Binding) {
        spirv[in.at + 3] = static_cast<std::uint32_t>(binding_of[in.w[0]]);
        have[in.w[0]] |= 2;
      }
    }
    if (in.op == spv::Decorate || in.op == spv::MemberDecorate) after_decorations = in.at + 1 + in.w.size();
  }
  std::vector<std::uint32_t> added;
  for (const auto& [id, b] : binding_of) {
    if (!(have[id] & 1))
      added.insert(added.end(),
                   {(4u << 16) | spv::Decorate, id, spv::DescriptorSet, static_cast<std::uint32_t>(kUserSet)});
    if (!(have[id] & 2))
      added.insert(added.end(), {(4u << 16) | spv::Decorate, id, spv::Binding, static_cast<std::uint32_t>(b)});
  }
  if (!added.empty() && after_decorations > 0)
    spirv.insert(spirv.begin() + static_cast<std::ptrdiff_t>(after_decorations), added.begin(), added.end());
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

}  // namespace glintlab::shader
