// The GPU back end (docs/GPU.md): a Vulkan compute device, its buffers and its kernels. This
// layer knows no equation: it holds data on the device and runs the compute shaders of the
// model layer (src/gpu/shaders, compiled to SPIR-V by glslc at build time), which sum what the
// model's algorithms define. Any Vulkan 1.1 device with 64-bit floats in its shaders serves:
// NVIDIA, AMD and Intel GPUs, and Mesa's lavapipe (Vulkan on the CPU) for tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace btfgmm {

// Where the work runs: kAuto takes a hardware GPU where one exists and the CPU otherwise
// (never a software Vulkan such as lavapipe); kGpu takes a hardware GPU, else a software one
// (for tests), else refuses; kCpu never opens a device.
enum class DeviceChoice { kAuto, kCpu, kGpu };

// "auto", "cpu", "gpu"; nullopt for any other word.
std::optional<DeviceChoice> parse_device_choice(std::string_view word);
std::string_view device_choice_name(DeviceChoice choice);

// A Vulkan device as the driver describes it.
struct DeviceInfo {
  std::string name;                    // e.g. "NVIDIA H200", "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string driver;                  // the driver's name and version, e.g. "NVIDIA 580.159.04"
  bool software = false;               // a CPU implementation (lavapipe, SwiftShader)
  std::uint64_t memory_bytes = 0;      // its largest device-local heap
  std::uint64_t max_buffer_bytes = 0;  // the largest storage buffer a kernel may bind
  // "NVIDIA H200 (Vulkan, NVIDIA 580.159.04)": how the plan and the provenance name it.
  std::string description() const;
};

class GpuBuffer;
class GpuKernel;

// One Vulkan device and a compute queue. Calls are synchronous: each returns when the device
// has finished. Errors (no memory, a lost device) throw Error(kIo) naming the device, the
// operation and `device` cpu as the way on.
class ComputeDevice {
 public:
  virtual ~ComputeDevice() = default;
  virtual const DeviceInfo& info() const = 0;
  // A buffer of `bytes` in the device's own memory; refused (Error(kArgument)) past its
  // largest buffer or its memory, with the bytes asked and the device's.
  virtual std::shared_ptr<GpuBuffer> buffer(std::size_t bytes) = 0;
  virtual void upload(GpuBuffer& to, std::span<const std::byte> bytes, std::size_t offset = 0) = 0;
  virtual void download(const GpuBuffer& from, std::span<std::byte> bytes,
                        std::size_t offset = 0) = 0;
  // The compute shader `name` (built into the library) taking `buffers` storage buffers at
  // bindings 0 .. buffers - 1 and `push_bytes` of push constants.
  virtual std::shared_ptr<GpuKernel> kernel(std::string_view name, int buffers,
                                            std::size_t push_bytes) = 0;
  // Runs `kernel` over groups_x x groups_y workgroups with `buffers` bound in order and
  // `push` as its push constants; returns when it has finished.
  virtual void run(GpuKernel& kernel, std::span<GpuBuffer* const> buffers,
                   std::span<const std::byte> push, std::uint32_t groups_x,
                   std::uint32_t groups_y = 1) = 0;

  template <typename T>
  void upload_values(GpuBuffer& to, std::span<const T> values) {
    upload(to, std::as_bytes(values));
  }
  template <typename T>
  void download_values(const GpuBuffer& from, std::span<T> values) {
    download(from, std::as_writable_bytes(values));
  }
};

// The device `choice` asks for: null for the CPU (kCpu; kAuto where no hardware GPU exists).
// kGpu with no Vulkan device at all throws Error(kArgument) naming `device` cpu. The devices
// are looked for once per process.
std::shared_ptr<ComputeDevice> open_compute_device(DeviceChoice choice);

}  // namespace btfgmm
