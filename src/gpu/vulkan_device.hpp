// The Vulkan implementation of ComputeDevice (include/btfgmm/gpu/compute_device.hpp): the
// device and its compute queue (vulkan_device.cpp: buffers and transfers), its kernels as
// compute pipelines (vulkan_kernel.cpp).
#pragma once

#include <vulkan/vulkan.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <tuple>

#include "btfgmm/gpu/compute_device.hpp"

namespace btfgmm {

class GpuBuffer {
 public:
  GpuBuffer(VkDevice d, VkBuffer b, VkDeviceMemory m, std::size_t bytes)
      : device(d), buffer(b), memory(m), size(bytes) {}
  ~GpuBuffer();
  GpuBuffer(const GpuBuffer&) = delete;
  GpuBuffer& operator=(const GpuBuffer&) = delete;
  VkDevice device;
  VkBuffer buffer;
  VkDeviceMemory memory;
  std::size_t size;
};

class GpuKernel {
 public:
  GpuKernel(VkDevice d, int n, std::size_t push) : device(d), buffers(n), push_bytes(push) {}
  ~GpuKernel();
  GpuKernel(const GpuKernel&) = delete;
  GpuKernel& operator=(const GpuKernel&) = delete;
  VkDevice device;
  int buffers;
  std::size_t push_bytes;
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
};

namespace detail {

// The description of a physical device (its name, driver, kind, memory and largest buffer).
DeviceInfo describe_device(VkPhysicalDevice pd);

class VulkanDevice final : public ComputeDevice {
 public:
  // On `pd` (whose instance outlives it), with a queue of `family`.
  VulkanDevice(VkPhysicalDevice pd, std::uint32_t family);
  ~VulkanDevice() override;

  const DeviceInfo& info() const override { return info_; }
  std::shared_ptr<GpuBuffer> buffer(std::size_t bytes) override;
  void upload(GpuBuffer& to, std::span<const std::byte> bytes, std::size_t offset) override;
  void download(const GpuBuffer& from, std::span<std::byte> bytes, std::size_t offset) override;
  std::shared_ptr<GpuKernel> kernel(std::string_view name, int buffers,
                                    std::size_t push_bytes) override;
  void run(GpuKernel& k, std::span<GpuBuffer* const> buffers, std::span<const std::byte> push,
           std::uint32_t groups_x, std::uint32_t groups_y) override;

 private:
  std::shared_ptr<GpuBuffer> make_buffer(std::size_t bytes, VkBufferUsageFlags usage,
                                         VkMemoryPropertyFlags want);
  void check_range(const GpuBuffer& b, std::size_t n, std::size_t offset) const;
  void begin();
  void submit_and_wait(const std::string& what);
  void copy(VkBuffer from, std::size_t from_offset, VkBuffer to, std::size_t to_offset,
            std::size_t n);
  void check(VkResult r, const std::string& what) const;

  VkPhysicalDevice physical_;
  DeviceInfo info_;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer commands_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  std::shared_ptr<GpuBuffer> staging_;
  void* mapped_ = nullptr;
  std::mutex mutex_;
  // Each kernel made once (its shader compiled by the driver) and kept: a command that runs the
  // same kernel on many batches (decode's images, sweep's models) builds its pipeline once.
  // run() binds its buffers and waits under mutex_, so callers may share one.
  std::map<std::tuple<std::string, int, std::size_t>, std::shared_ptr<GpuKernel>> kernels_;
};

}  // namespace detail
}  // namespace btfgmm
