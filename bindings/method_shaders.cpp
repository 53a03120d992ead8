// Method shaders (glintlab/validation/method_shader.hpp) as _core.MethodKernel: compiled once, run on
// (rows, kMethodInputWords) uint32 input rows (float32 bits and integers, the GlintInput layout), returning (rows, 4)
// float32. glintlab.api.method_shaders packs the rows and reads the files.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/wb16.hpp"
#include "glintlab/validation/method_shader.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

static_assert(wb16::kInputWords == shader::kMethodInputWords, "WB16's twin reads the method contract's rows");

namespace {
// Its own Python type (ShaderKernel already binds shader::Kernel): a compiled method shader.
struct MethodKernel {
  std::shared_ptr<shader::Kernel> kernel;
  bool fragment = false;  // the fragment mode: rows of kFragmentInputWords, a quad per row
};
}  // namespace

void bind_method_shaders(py::module_& m) {
  using Rows = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>;
  m.attr("METHOD_INPUT_WORDS") = shader::kMethodInputWords;
  m.attr("METHOD_OUTPUT_WORDS") = shader::kMethodOutputWords;
  m.attr("FRAGMENT_INPUT_WORDS") = shader::kFragmentInputWords;
  m.def("fragment_wrapper_source", &shader::fragment_wrapper_source, py::arg("assign"), py::arg("output"),
        py::arg("include_name"));
  m.def("method_wrapper_source", &shader::method_wrapper_source, py::arg("language"), py::arg("entry"),
        py::arg("include_name"));
  // GlintInput's fields as the wrapper's declaration reads them: (name, GLSL type, first word).
  py::list fields;
  for (const auto& f : shader::method_wrapper("glint").fields) fields.append(py::make_tuple(f.name, f.type, f.word));
  m.attr("METHOD_INPUT_FIELDS") = py::tuple(fields);
  py::class_<MethodKernel>(m, "MethodKernel")
      .def(py::init([](const std::string& source, const std::string& source_name, const std::string& entry,
                       const std::string& language, const std::vector<std::pair<std::string, std::string>>& defines,
                       const std::vector<std::string>& include_dirs, const std::string& device,
                       const std::vector<std::pair<std::string, std::string>>& include_files) {
             shader::KernelSpec spec{source,  source_name,  entry,  language,     0,
                                     defines, include_dirs, device, include_files};
             glintlab::bindings::LongCall release;
             return MethodKernel{shader::method_kernel(spec)};
           }),
           py::arg("source"), py::arg("source_name"), py::arg("entry"), py::arg("language"), py::arg("defines"),
           py::arg("include_dirs"), py::arg("device"),
           py::arg("include_files") = std::vector<std::pair<std::string, std::string>>{})
      .def_static(
          "fragment",
          [](const std::string& source, const std::string& source_name, const std::string& assign,
             const std::string& output, const std::vector<std::pair<std::string, std::string>>& defines,
             const std::vector<std::string>& include_dirs, const std::string& device,
             const std::vector<std::pair<std::string, std::string>>& include_files) {
            shader::KernelSpec spec{source, source_name, "main", "glsl", 0, defines, include_dirs, device, include_files};
            glintlab::bindings::LongCall release;
            return MethodKernel{shader::fragment_kernel(spec, assign, output), true};
          },
          py::arg("source"), py::arg("source_name"), py::arg("assign"), py::arg("output"), py::arg("defines"),
          py::arg("include_dirs"), py::arg("device"),
          py::arg("include_files") = std::vector<std::pair<std::string, std::string>>{})
      .def_property_readonly("device", [](const MethodKernel& k) { return k.kernel->device_name(); })
      .def_property_readonly("device_type", [](const MethodKernel& k) { return k.kernel->device_type(); })
      .def_property_readonly("unbounded_loops", [](const MethodKernel& k) { return k.kernel->unbounded_loops(); })
      .def_property_readonly("declared_resources", [](const MethodKernel& k) { return declared_resources(*k.kernel); })
      .def("bind_resources", [](const MethodKernel& k, const py::list& data) { bind_resources(*k.kernel, data); },
           py::arg("data"))
      .def_property_readonly("included_files",
                             [](const MethodKernel& k) {
                               py::list out;  // content as bytes: a header need not be valid UTF-8
                               for (const auto& [path, content] : k.kernel->included_files())
                                 out.append(py::make_tuple(path, py::bytes(content)));
                               return out;
                             })
      .def_property_readonly("spirv",
                             [](const MethodKernel& k) {
                               const auto& w = k.kernel->spirv();
                               return py::bytes(reinterpret_cast<const char*>(w.data()),
                                                w.size() * sizeof(std::uint32_t));
                             })
      .def(
          "run",
          [](const MethodKernel& k, const Rows& rows, double timeout, bool timing) {
            const std::size_t words = k.fragment ? shader::kFragmentInputWords : shader::kMethodInputWords;
            if (rows.ndim() != 2 || static_cast<std::size_t>(rows.shape(1)) != words)
              glintlab::throw_invalid_message("rows must have shape (count, " + std::to_string(words) + ")");
            const auto count = static_cast<std::size_t>(rows.shape(0));
            py::array_t<float> out(
                {static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(shader::kMethodOutputWords)});
            const auto* in = reinterpret_cast<const float*>(rows.data());
            float* od = out.mutable_data();
            const auto ms = long_call_timed(timing, [&] {
              if (k.fragment)
                shader::run_fragment(*k.kernel, in, count, od, timeout);
              else
                shader::run_method(*k.kernel, in, count, od, timeout);
            });
            if (!timing) return py::object(out);
            return py::object(py::make_tuple(out, ms));
          },
          py::arg("rows"), py::arg("timeout"), py::arg("timing") = false);
}

}  // namespace glintlab::bindings
