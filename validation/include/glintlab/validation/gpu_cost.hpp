// What a real GPU compiler makes of a kernel glintlab runs, without a GPU (docs/guide/gpu_cost.md).
//
// Mesa's RADV driver (Debian package mesa-vulkan-drivers) creates a "null" device when the environment
// variable RADV_FORCE_FAMILY names an AMD GPU family: nothing executes on it, but pipelines compile through
// ACO, the compiler AMD GPUs run under Linux, and VK_KHR_pipeline_executable_properties reports per
// pipeline its instructions, registers, spills, occupancy and ACO's latency and inverse-throughput
// estimates, and its internal representations (NIR, ACO IR, the ISA).
//
// Policy: the driver library is opened directly (dlopen, its ICD entry point), never through the Vulkan
// loader, so the shader runner's own instance (lavapipe) never sees a null device. RADV reads
// RADV_FORCE_FAMILY when an instance enumerates its devices: each architecture gets its own instance and
// device, created once per process (the instance under a lock with the variable set for that moment only, the
// device under the architecture's own lock, so architectures' devices are made side by side), and kept.
// RADV aborts the process on a family it does not know, so a name is checked first against this
// table and against the driver library's own family names.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace glintlab::gpu_cost {

// RADV cannot be opened (not installed, or a library without the ICD entry point) (Python: RuntimeError).
class CompilerMissing : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An AMD architecture: the RADV family name and the GPU the cost model spreads waves over.
struct Architecture {
  std::string name;        // RADV_FORCE_FAMILY value, e.g. "navi21"
  std::string generation;  // "GCN4", "GCN5", "RDNA1", "RDNA2", "RDNA3"
  std::string gpu;         // the named GPU, e.g. "Radeon RX 6900 XT"
  int wave_size = 64;      // lanes per wave the kernel is compiled for (RDNA: 32, GCN: 64)
  int compute_units = 0;   // of the named GPU
  int simds_per_cu = 4;    // GCN: 4 SIMD16; RDNA: 2 SIMD32
  double clock_mhz = 0.0;  // the named GPU's boost clock
};

// The architectures glintlab knows, in a fixed order.
const std::vector<Architecture>& architectures();

// The names of architectures() the installed driver also knows (empty when RADV is missing).
std::vector<std::string> known_architectures();

// The driver library path and why it could not be opened ("" when it can).
struct DriverStatus {
  std::string library;
  std::string error;
};
DriverStatus driver_status();

struct PipelineStats {
  std::string arch;
  std::string device_name;                                           // "Null hardware (RADV NAVI21)"
  std::string driver;                                                // "radv Mesa 22.3.6"
  int subgroup_size = 0;                                             // the wave size the pipeline was compiled for
  std::vector<std::pair<std::string, double>> statistics;            // in the driver's order
  std::vector<std::pair<std::string, std::string>> representations;  // "NIR Shader(s)", "ACO IR", "Assembly"
};

// Compiles a compute kernel's SPIR-V (its entry point read from the module; resources: glintlab's
// runner layout, storage buffers at set 0 bindings 0-3 and a push constant) for `arch` at the
// architecture's wave size. Throws std::invalid_argument for an unknown architecture or SPIR-V that is
// not a compute module, CompilerMissing when RADV cannot be opened, std::runtime_error when the
// driver refuses the pipeline.
PipelineStats compile_stats(const std::vector<std::uint32_t>& spirv, const std::string& arch,
                            bool representations = false);

// Makes the null devices of `archs` ahead of their compiles: their instances on this thread (RADV reads the
// environment then), and with `devices` their logical devices, each on a thread of its own. The same
// refusals as compile_stats for an unknown architecture or a missing RADV. A caller can run the second
// step (devices = true, after a first call with false) on a thread of its own beside other work.
void open_devices(const std::vector<std::string>& archs, bool devices);

// compile_stats of every module of `spirvs` for every architecture of `archs`, the architectures on
// threads of their own (a device's creation, about 0.2 s of CPU on RDNA2 and later, and the compiles run
// side by side): element [i * spirvs.size() + j] is module j on archs[i]. The same refusals, before any
// compile.
std::vector<PipelineStats> compile_stats_many(const std::vector<std::vector<std::uint32_t>>& spirvs,
                                              const std::vector<std::string>& archs, bool representations = false);

}  // namespace glintlab::gpu_cost
