// The GPU compiler statistics (glintlab/validation/gpu_cost.hpp) as _core.gpu_compile_stats,
// _core.gpu_architectures and _core.gpu_driver. The Python layer (glintlab.api.gpu_cost) builds the tables.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/validation/gpu_cost.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

std::vector<std::uint32_t> words_of(const py::bytes& spirv) {
  const std::string bytes = spirv;
  if (bytes.size() % 4 != 0)
    throw_invalid_message("gpu_compile_stats: spirv: " + std::to_string(bytes.size()) +
                          " bytes, not a whole number of 32-bit words");
  std::vector<std::uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  return words;
}

py::dict as_dict(const gpu_cost::PipelineStats& s) {
  py::dict out;
  out["arch"] = s.arch;
  out["device_name"] = s.device_name;
  out["driver"] = s.driver;
  out["subgroup_size"] = s.subgroup_size;
  out["statistics"] = s.statistics;
  out["representations"] = s.representations;
  return out;
}

}  // namespace

void bind_gpu_cost(py::module_& m) {
  namespace gc = gpu_cost;
  py::register_exception<gc::CompilerMissing>(m, "GpuCompilerMissing", PyExc_RuntimeError);
  m.def("gpu_architectures", [] {
    py::list out;
    for (const auto& a : gc::architectures()) {
      py::dict x;
      x["arch"] = a.name;
      x["generation"] = a.generation;
      x["gpu"] = a.gpu;
      x["wave_size"] = a.wave_size;
      x["compute_units"] = a.compute_units;
      x["simds_per_cu"] = a.simds_per_cu;
      x["clock_mhz"] = a.clock_mhz;
      out.append(x);
    }
    return out;
  });
  m.def("gpu_known_architectures", &gc::known_architectures);
  m.def("gpu_driver", [] {
    const auto s = gc::driver_status();
    return py::make_tuple(s.library, s.error);
  });
  m.def(
      "gpu_compile_stats",
      [](const py::bytes& spirv, const std::string& arch, bool representations) {
        const auto words = words_of(spirv);
        gc::PipelineStats s;
        {
          py::gil_scoped_release release;
          s = gc::compile_stats(words, arch, representations);
        }
        return as_dict(s);
      },
      py::arg("spirv"), py::arg("arch"), py::arg("representations") = false);
  m.def(
      "gpu_open_devices",
      [](const std::vector<std::string>& archs, bool devices) {
        py::gil_scoped_release release;
        gc::open_devices(archs, devices);
      },
      py::arg("archs"), py::arg("devices"));
  m.def(
      "gpu_compile_stats_many",
      [](const std::vector<py::bytes>& spirvs, const std::vector<std::string>& archs, bool representations) {
        std::vector<std::vector<std::uint32_t>> modules;
        for (const auto& s : spirvs) modules.push_back(words_of(s));
        std::vector<gc::PipelineStats> stats;
        {
          py::gil_scoped_release release;
          stats = gc::compile_stats_many(modules, archs, representations);
        }
        py::list out;
        for (const auto& s : stats) out.append(as_dict(s));
        return out;
      },
      py::arg("spirvs"), py::arg("archs"), py::arg("representations") = false);
}

}  // namespace glintlab::bindings
