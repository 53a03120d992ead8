// Shader samplers (glintlab/validation/sampler_shader.hpp) as _core.SamplerKernel: compiled once, run on
// (rows, 16) uint32 input rows (float32 bits and the mode word), returning (rows, 4) float32.
// glintlab.api.shader_samplers packs the rows, draws the uniforms and reads the files.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/validation/sampler_shader.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

namespace {
// Its own Python type (ShaderKernel already binds shader::Kernel): a compiled shader sampler.
struct SamplerKernel {
  std::shared_ptr<shader::Kernel> kernel;
};
}  // namespace

void bind_sampler_shaders(py::module_& m) {
  using Rows = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>;
  m.attr("SAMPLER_INPUT_WORDS") = shader::kSamplerInputWords;
  m.attr("SAMPLER_OUTPUT_WORDS") = shader::kSamplerOutputWords;
  m.def("sampler_wrapper_source", &shader::sampler_wrapper_source, py::arg("language"), py::arg("sample_entry"),
        py::arg("pdf_entry"), py::arg("include_name"), py::arg("contract") = "h");
  m.def("sampler_signature", &shader::sampler_signature, py::arg("language"), py::arg("sample_entry"),
        py::arg("pdf_entry"), py::arg("contract") = "h");
  m.def(
      "sampler_functions",
      [](const std::string& source, const std::string& source_name, const std::string& language,
         const std::vector<std::pair<std::string, std::string>>& defines, const std::vector<std::string>& include_dirs,
         const std::vector<std::pair<std::string, std::string>>& include_files) {
        shader::KernelSpec spec{source,  source_name,  "sample_h", language,     0,
                                defines, include_dirs, "auto",     include_files};
        return shader::sampler_functions(spec);
      },
      py::arg("source"), py::arg("source_name"), py::arg("language"), py::arg("defines"), py::arg("include_dirs"),
      py::arg("include_files") = std::vector<std::pair<std::string, std::string>>{});
  py::class_<SamplerKernel>(m, "SamplerKernel")
      .def(py::init([](const std::string& source, const std::string& source_name, const std::string& sample_entry,
                       const std::string& pdf_entry, const std::string& language,
                       const std::vector<std::pair<std::string, std::string>>& defines,
                       const std::vector<std::string>& include_dirs, const std::string& device,
                       const std::vector<std::pair<std::string, std::string>>& include_files,
                       const std::string& contract) {
             shader::KernelSpec spec{source, source_name, sample_entry, language, 0, defines, include_dirs, device,
                                     include_files};
             glintlab::bindings::LongCall release;
             return SamplerKernel{shader::sampler_kernel(spec, pdf_entry, contract)};
           }),
           py::arg("source"), py::arg("source_name"), py::arg("sample_entry"), py::arg("pdf_entry"),
           py::arg("language"), py::arg("defines"), py::arg("include_dirs"), py::arg("device"),
           py::arg("include_files") = std::vector<std::pair<std::string, std::string>>{},
           py::arg("contract") = "h")
      .def_property_readonly("device", [](const SamplerKernel& k) { return k.kernel->device_name(); })
      .def_property_readonly("device_type", [](const SamplerKernel& k) { return k.kernel->device_type(); })
      .def_property_readonly("unbounded_loops", [](const SamplerKernel& k) { return k.kernel->unbounded_loops(); })
      .def_property_readonly("declared_resources", [](const SamplerKernel& k) { return declared_resources(*k.kernel); })
      .def("bind_resources", [](const SamplerKernel& k, const py::list& data) { bind_resources(*k.kernel, data); },
           py::arg("data"))
      .def_property_readonly("included_files", [](const SamplerKernel& k) {
             py::list out;  // content as bytes: a header need not be valid UTF-8
             for (const auto& [path, content] : k.kernel->included_files())
               out.append(py::make_tuple(path, py::bytes(content)));
             return out;
           })
      .def_property_readonly("spirv", [](const SamplerKernel& k) {
             const auto& w = k.kernel->spirv();
             return py::bytes(reinterpret_cast<const char*>(w.data()), w.size() * sizeof(std::uint32_t));
           })
      .def("run", [](const SamplerKernel& k, const Rows& rows, double timeout) {
             if (rows.ndim() != 2 || static_cast<std::size_t>(rows.shape(1)) != shader::kSamplerInputWords)
               glintlab::throw_invalid_message("rows must have shape (count, " +
                                               std::to_string(shader::kSamplerInputWords) + ")");
             const auto count = static_cast<std::size_t>(rows.shape(0));
             py::array_t<float> out({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(shader::kSamplerOutputWords)});
             const auto* in = reinterpret_cast<const float*>(rows.data());
             float* od = out.mutable_data();
             {
               glintlab::bindings::LongCall release;
               shader::run_sampler(*k.kernel, in, count, od, timeout);
             }
             return out;
           },
           py::arg("rows"), py::arg("timeout"));
}

}  // namespace glintlab::bindings
