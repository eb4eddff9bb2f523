// The choice of a compute device and its discovery (include/btfgmm/gpu/compute_device.hpp):
// the Vulkan instance, the physical devices that can run the shaders (a compute queue, 64-bit
// floats), the best of them by kind, opened once per process.
#include "btfgmm/gpu/compute_device.hpp"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <mutex>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "gpu/vulkan_check.hpp"
#include "gpu/vulkan_device.hpp"

namespace btfgmm {

std::optional<DeviceChoice> parse_device_choice(std::string_view word) {
  if (word == "auto") return DeviceChoice::kAuto;
  if (word == "cpu") return DeviceChoice::kCpu;
  if (word == "gpu") return DeviceChoice::kGpu;
  return std::nullopt;
}

std::string_view device_choice_name(DeviceChoice choice) {
  switch (choice) {
    case DeviceChoice::kAuto:
      return "auto";
    case DeviceChoice::kCpu:
      return "cpu";
    case DeviceChoice::kGpu:
      return "gpu";
  }
  return "auto";
}

std::string DeviceInfo::description() const {
  return name + " (Vulkan, " + driver + (software ? ", software" : "") + ")";
}

namespace {

// A physical device that can run the shaders, and its rank: discrete GPUs first, then
// integrated, virtual and other GPUs, software implementations last.
struct Candidate {
  VkPhysicalDevice device;
  std::uint32_t family;
  int rank;
};

int kind_rank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 4;
    default:
      return 3;
  }
}

// The queue family with compute, or nullopt.
std::optional<std::uint32_t> compute_family(VkPhysicalDevice pd) {
  std::uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, families.data());
  for (std::uint32_t i = 0; i < n; ++i)
    if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) return i;
  return std::nullopt;
}

std::optional<Candidate> candidate(VkPhysicalDevice pd) {
  VkPhysicalDeviceProperties p;
  vkGetPhysicalDeviceProperties(pd, &p);
  VkPhysicalDeviceFeatures f;
  vkGetPhysicalDeviceFeatures(pd, &f);
  const auto family = compute_family(pd);
  if (!family || !f.shaderFloat64 || p.apiVersion < VK_API_VERSION_1_1) return std::nullopt;
  return Candidate{pd, *family, kind_rank(p.deviceType)};
}

VkInstance make_instance() {
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "btfgmm";
  app.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo c{};
  c.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  c.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  if (vkCreateInstance(&c, nullptr, &instance) != VK_SUCCESS) return VK_NULL_HANDLE;
  return instance;
}

// The devices of one process: the best hardware GPU and the best of any kind, each opened
// the first time it is asked for (never closed: the driver's state lives as long as the
// process).
struct Devices {
  std::mutex mutex;
  bool looked = false;
  VkInstance instance = VK_NULL_HANDLE;
  std::vector<Candidate> found;  // best first
  std::shared_ptr<ComputeDevice> opened;

  void look() {
    if (looked) return;
    looked = true;
    instance = make_instance();
    if (!instance) return;
    std::uint32_t n = 0;
    vkEnumeratePhysicalDevices(instance, &n, nullptr);
    std::vector<VkPhysicalDevice> all(n);
    vkEnumeratePhysicalDevices(instance, &n, all.data());
    for (VkPhysicalDevice pd : all)
      if (auto c = candidate(pd)) found.push_back(*c);
    std::stable_sort(found.begin(), found.end(),
                     [](const Candidate& a, const Candidate& b) { return a.rank < b.rank; });
  }
};

Devices& devices() {
  static Devices* d = new Devices;  // never destroyed (Devices)
  return *d;
}

}  // namespace

std::shared_ptr<ComputeDevice> open_compute_device(DeviceChoice choice) {
  if (choice == DeviceChoice::kCpu) return nullptr;
  Devices& d = devices();
  const std::lock_guard lock(d.mutex);
  d.look();
  const bool hardware = !d.found.empty() && d.found.front().rank < 4;
  if (choice == DeviceChoice::kAuto && !hardware) return nullptr;
  if (d.found.empty())
    throw Error(Error::Kind::kArgument,
                "no Vulkan device that can run btfgmm's shaders (a compute queue and 64-bit "
                "floats) was found: install the GPU's Vulkan driver (for a test without a GPU, "
                "Mesa's lavapipe: Debian's mesa-vulkan-drivers), or run it on the CPU (" +
                    option_name("device") + " cpu)");
  if (!d.opened)
    d.opened =
        std::make_shared<detail::VulkanDevice>(d.found.front().device, d.found.front().family);
  return d.opened;
}

}  // namespace btfgmm
