// Shader laws (glintlab/validation/shader.hpp): the Vulkan runner as _core.ShaderKernel and
// _core.vulkan_devices. The Python layer (glintlab.api.shaders) reads files and builds the law.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/validation/shader.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

py::list declared_resources(const shader::Kernel& k) {
  py::list out;
  for (const auto& r : k.declared_resources()) {
    py::dict x;
    x["name"] = r.name;
    x["kind"] = r.kind;
    x["binding"] = r.binding;
    x["dims"] = r.dims;
    x["arrayed"] = r.arrayed;
    x["scalar"] = r.scalar;
    x["channels"] = r.channels;
    x["size"] = r.size;
    py::list members;
    for (const auto& mb : r.members) {
      py::dict y;
      y["name"] = mb.name;
      y["offset"] = mb.offset;
      y["scalar"] = mb.scalar;
      y["components"] = mb.components;
      y["count"] = mb.count;
      y["array_stride"] = mb.array_stride;
      members.append(y);
    }
    x["members"] = members;
    out.append(x);
  }
  return out;
}

void bind_resources(shader::Kernel& k, const py::list& data) {
  using Words = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>;
  std::vector<shader::ResourceData> out;
  for (const auto& item : data) {
    const auto d = item.cast<py::dict>();
    shader::ResourceData r;
    r.name = d["name"].cast<std::string>();
    for (const auto& level : d["levels"].cast<py::list>()) {
      const Words w = level.cast<Words>();
      r.levels.emplace_back(w.data(), w.data() + w.size());
    }
    if (d.contains("extent")) {
      const auto e = d["extent"].cast<std::vector<std::uint32_t>>();
      for (std::size_t i = 0; i < 4 && i < e.size(); ++i) r.extent[i] = e[i];
    }
    if (d.contains("channels")) r.channels = d["channels"].cast<int>();
    if (d.contains("filter")) r.filter = d["filter"].cast<std::string>();
    if (d.contains("address")) r.address = d["address"].cast<std::string>();
    out.push_back(std::move(r));
  }
  glintlab::bindings::LongCall release;
  k.bind_resources(out);
}

void bind_shaders(py::module_& m) {
  using shader::Kernel;
  using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
  py::register_exception<shader::ShaderTimeout>(m, "ShaderTimeout", PyExc_TimeoutError);
  py::register_exception<shader::NoVulkanDevice>(m, "NoVulkanDevice", PyExc_RuntimeError);
  // After ShaderTimeout: pybind tries the translators registered last first, so the subclass wins.
  py::register_exception<shader::ShaderDeviceBusy>(m, "ShaderDeviceBusy", PyExc_TimeoutError);

  m.def("vulkan_devices", [] {
    py::list out;
    for (const auto& d : shader::vulkan_devices()) {
      py::dict x;
      x["index"] = d.index;
      x["name"] = d.name;
      x["type"] = d.type;
      x["api_version"] = d.api_version;
      x["driver"] = d.driver;
      out.append(x);
    }
    return out;
  });
  m.def("shader_wrapper_source", &shader::wrapper_source, py::arg("language"), py::arg("entry"),
        py::arg("include_name"));

  py::class_<Kernel, std::shared_ptr<Kernel>>(m, "ShaderKernel")
      .def(py::init([](const std::string& source, const std::string& source_name, const std::string& entry,
                       const std::string& language, int n_uniforms,
                       const std::vector<std::pair<std::string, std::string>>& defines,
                       const std::vector<std::string>& include_dirs, const std::string& device,
                       const std::vector<std::pair<std::string, std::string>>& include_files) {
             shader::KernelSpec spec{source,  source_name,  entry,  language,     n_uniforms,
                                     defines, include_dirs, device, include_files};
             glintlab::bindings::LongCall release;
             return std::make_shared<Kernel>(spec);
           }),
           py::arg("source"), py::arg("source_name"), py::arg("entry"), py::arg("language"), py::arg("n_uniforms"),
           py::arg("defines"), py::arg("include_dirs"), py::arg("device"),
           py::arg("include_files") = std::vector<std::pair<std::string, std::string>>{})
      .def_property_readonly("device", &Kernel::device_name)
      .def_property_readonly("device_type", &Kernel::device_type)
      .def_property_readonly("n_uniforms", &Kernel::n_uniforms)
      .def_property_readonly("included_files",
                             [](const Kernel& k) {
                               py::list out;  // content as bytes: a header need not be valid UTF-8
                               for (const auto& [path, content] : k.included_files())
                                 out.append(py::make_tuple(path, py::bytes(content)));
                               return out;
                             })
      .def_property_readonly("unbounded_loops", &Kernel::unbounded_loops)
      .def_property_readonly("declared_resources", [](const Kernel& k) { return declared_resources(k); })
      .def(
          "bind_resources", [](Kernel& k, const py::list& data) { bind_resources(k, data); }, py::arg("data"))
      .def_property_readonly("spirv",
                             [](const Kernel& k) {
                               return py::bytes(reinterpret_cast<const char*>(k.spirv().data()),
                                                k.spirv().size() * sizeof(std::uint32_t));
                             })
      .def(
          "run",
          [](const Kernel& k, const Array& n, const Array& p, const Array& u, double timeout, bool timing) {
            const auto count = static_cast<std::size_t>(u.ndim() == 2 ? u.shape(0) : 0);
            const auto kk = static_cast<std::size_t>(k.n_uniforms());
            if (u.ndim() != 2 || static_cast<std::size_t>(u.shape(1)) != kk)
              glintlab::throw_invalid_message("u must have shape (rows, " + std::to_string(kk) + ")");
            py::array_t<float> out(static_cast<py::ssize_t>(count));
            const double* nd = n.data();
            const double* pd = p.data();
            const double* ud = u.data();
            float* od = out.mutable_data();
            const auto ns = static_cast<std::size_t>(n.size()), ps = static_cast<std::size_t>(p.size());
            const auto ms = long_call_timed(timing, [&] { k.run(nd, ns, pd, ps, ud, count, od, timeout); });
            if (!timing) return py::object(out);
            return py::object(py::make_tuple(out, ms));
          },
          py::arg("n"), py::arg("p"), py::arg("u"), py::arg("timeout"), py::arg("timing") = false);
}

}  // namespace glintlab::bindings
