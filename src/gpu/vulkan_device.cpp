// The Vulkan device (vulkan_device.hpp): one compute queue, device-local buffers filled and
// read through a host-visible staging buffer, every submission waited for.
#include "gpu/vulkan_device.hpp"

#include <algorithm>
#include <cstring>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "gpu/vulkan_check.hpp"

namespace btfgmm {

GpuBuffer::~GpuBuffer() {
  vkDestroyBuffer(device, buffer, nullptr);
  vkFreeMemory(device, memory, nullptr);
}

namespace detail {
namespace {

// Transfers go through a staging buffer of this size, in pieces.
constexpr std::size_t kStagingBytes = 64u << 20;

// The largest device-local heap.
std::uint64_t device_memory(VkPhysicalDevice pd) {
  VkPhysicalDeviceMemoryProperties mp;
  vkGetPhysicalDeviceMemoryProperties(pd, &mp);
  std::uint64_t most = 0;
  for (std::uint32_t h = 0; h < mp.memoryHeapCount; ++h)
    if (mp.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      most = std::max<std::uint64_t>(most, mp.memoryHeaps[h].size);
  return most;
}

std::uint32_t memory_type(VkPhysicalDevice pd, std::uint32_t allowed, VkMemoryPropertyFlags want) {
  VkPhysicalDeviceMemoryProperties mp;
  vkGetPhysicalDeviceMemoryProperties(pd, &mp);
  for (std::uint32_t i = 0; i < mp.memoryTypeCount; ++i)
    if ((allowed & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) return i;
  return UINT32_MAX;
}

}  // namespace

DeviceInfo describe_device(VkPhysicalDevice pd) {
  VkPhysicalDeviceDriverProperties driver{};
  driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
  VkPhysicalDeviceProperties2 p2{};
  p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  p2.pNext = &driver;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  DeviceInfo info;
  info.name = p2.properties.deviceName;
  info.driver = std::string(driver.driverName);
  if (driver.driverInfo[0]) info.driver += std::string(" ") + driver.driverInfo;
  info.software = p2.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  info.memory_bytes = device_memory(pd);
  info.max_buffer_bytes = p2.properties.limits.maxStorageBufferRange;
  return info;
}

VulkanDevice::VulkanDevice(VkPhysicalDevice pd, std::uint32_t family)
    : physical_(pd), info_(describe_device(pd)) {
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo q{};
  q.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  q.queueFamilyIndex = family;
  q.queueCount = 1;
  q.pQueuePriorities = &priority;
  VkPhysicalDeviceFeatures features{};
  features.shaderFloat64 = VK_TRUE;
  VkDeviceCreateInfo d{};
  d.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  d.queueCreateInfoCount = 1;
  d.pQueueCreateInfos = &q;
  d.pEnabledFeatures = &features;
  check(vkCreateDevice(pd, &d, nullptr, &device_), "creating its device");
  vkGetDeviceQueue(device_, family, 0, &queue_);
  VkCommandPoolCreateInfo pool{};
  pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool.queueFamilyIndex = family;
  check(vkCreateCommandPool(device_, &pool, nullptr, &pool_), "creating a command pool");
  VkCommandBufferAllocateInfo a{};
  a.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  a.commandPool = pool_;
  a.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  a.commandBufferCount = 1;
  check(vkAllocateCommandBuffers(device_, &a, &commands_), "allocating a command buffer");
  VkFenceCreateInfo f{};
  f.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  check(vkCreateFence(device_, &f, nullptr, &fence_), "creating a fence");
  staging_ = make_buffer(
      kStagingBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  check(vkMapMemory(device_, staging_->memory, 0, VK_WHOLE_SIZE, 0, &mapped_),
        "mapping its staging buffer");
}

VulkanDevice::~VulkanDevice() {
  vkDeviceWaitIdle(device_);
  kernels_.clear();
  staging_.reset();
  if (fence_) vkDestroyFence(device_, fence_, nullptr);
  if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
  vkDestroyDevice(device_, nullptr);
}

void VulkanDevice::check(VkResult r, const std::string& what) const {
  vulkan_check(r, what, info_.name);
}

std::shared_ptr<GpuBuffer> VulkanDevice::buffer(std::size_t bytes) {
  const std::uint64_t most = std::min(info_.max_buffer_bytes, info_.memory_bytes);
  if (bytes > most)
    throw Error(Error::Kind::kArgument,
                "the GPU " + info_.name + " cannot hold a buffer of " + human_bytes(double(bytes)) +
                    " (its largest: " + human_bytes(double(most)) +
                    "); fit a smaller tile, or on the CPU (" + option_name("device") + " cpu)");
  return make_buffer(std::max<std::size_t>(bytes, 16),
                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                         VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
}

std::shared_ptr<GpuBuffer> VulkanDevice::make_buffer(std::size_t bytes, VkBufferUsageFlags usage,
                                                     VkMemoryPropertyFlags want) {
  VkBufferCreateInfo b{};
  b.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  b.size = bytes;
  b.usage = usage;
  b.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkBuffer buffer = VK_NULL_HANDLE;
  check(vkCreateBuffer(device_, &b, nullptr, &buffer), "creating a buffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device_, buffer, &req);
  VkMemoryAllocateInfo a{};
  a.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  a.allocationSize = req.size;
  a.memoryTypeIndex = memory_type(physical_, req.memoryTypeBits, want);
  VkDeviceMemory memory = VK_NULL_HANDLE;
  const VkResult r = a.memoryTypeIndex == UINT32_MAX
                         ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                         : vkAllocateMemory(device_, &a, nullptr, &memory);
  if (r != VK_SUCCESS) vkDestroyBuffer(device_, buffer, nullptr);
  check(r, "allocating " + human_bytes(double(bytes)));
  vkBindBufferMemory(device_, buffer, memory, 0);
  return std::make_shared<GpuBuffer>(device_, buffer, memory, bytes);
}

void VulkanDevice::check_range(const GpuBuffer& b, std::size_t n, std::size_t offset) const {
  if (offset > b.size || n > b.size - offset)
    throw Error(Error::Kind::kArgument, "a transfer of " + std::to_string(n) + " bytes at " +
                                            std::to_string(offset) + " outside a GPU buffer of " +
                                            std::to_string(b.size) + " bytes");
}

void VulkanDevice::upload(GpuBuffer& to, std::span<const std::byte> bytes, std::size_t offset) {
  check_range(to, bytes.size(), offset);
  for (std::size_t done = 0; done < bytes.size(); done += kStagingBytes) {
    const std::size_t n = std::min(kStagingBytes, bytes.size() - done);
    std::memcpy(mapped_, bytes.data() + done, n);
    copy(staging_->buffer, 0, to.buffer, offset + done, n);
  }
}

void VulkanDevice::download(const GpuBuffer& from, std::span<std::byte> bytes, std::size_t offset) {
  check_range(from, bytes.size(), offset);
  for (std::size_t done = 0; done < bytes.size(); done += kStagingBytes) {
    const std::size_t n = std::min(kStagingBytes, bytes.size() - done);
    copy(from.buffer, offset + done, staging_->buffer, 0, n);
    std::memcpy(bytes.data() + done, mapped_, n);
  }
}

void VulkanDevice::begin() {
  check(vkResetCommandBuffer(commands_, 0), "resetting its commands");
  VkCommandBufferBeginInfo b{};
  b.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  b.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(commands_, &b), "recording commands");
}

void VulkanDevice::submit_and_wait(const std::string& what) {
  check(vkEndCommandBuffer(commands_), what);
  VkSubmitInfo s{};
  s.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  s.commandBufferCount = 1;
  s.pCommandBuffers = &commands_;
  check(vkQueueSubmit(queue_, 1, &s, fence_), what);
  check(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX), what);
  check(vkResetFences(device_, 1, &fence_), what);
}

void VulkanDevice::copy(VkBuffer from, std::size_t from_offset, VkBuffer to, std::size_t to_offset,
                        std::size_t n) {
  const std::lock_guard lock(mutex_);
  begin();
  const VkBufferCopy region{from_offset, to_offset, n};
  vkCmdCopyBuffer(commands_, from, to, 1, &region);
  submit_and_wait("copying " + human_bytes(double(n)));
}

}  // namespace detail
}  // namespace btfgmm
