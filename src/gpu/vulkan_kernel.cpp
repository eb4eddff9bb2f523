// Kernels of the Vulkan device (vulkan_device.hpp): a compute pipeline from a built-in
// shader's SPIR-V, its storage buffers in one descriptor set, its push constants; and running
// one over a grid of workgroups, waited for.
#include <cstring>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "gpu/shaders.hpp"
#include "gpu/vulkan_check.hpp"
#include "gpu/vulkan_device.hpp"

namespace btfgmm {

GpuKernel::~GpuKernel() {
  if (pipeline) vkDestroyPipeline(device, pipeline, nullptr);
  if (layout) vkDestroyPipelineLayout(device, layout, nullptr);
  if (pool) vkDestroyDescriptorPool(device, pool, nullptr);
  if (set_layout) vkDestroyDescriptorSetLayout(device, set_layout, nullptr);
  if (module) vkDestroyShaderModule(device, module, nullptr);
}

namespace detail {
namespace {

// The SPIR-V words of a built-in shader (copied: the embedded bytes need not be aligned).
std::vector<std::uint32_t> spirv_words(std::string_view name) {
  const std::string_view bytes = gpu_shader(name);
  if (bytes.empty() || bytes.size() % 4 != 0)
    throw Error(Error::Kind::kArgument, "no GPU shader named " + std::string(name));
  std::vector<std::uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  return words;
}

void make_descriptors(VkDevice device, GpuKernel& k, const std::string& name) {
  std::vector<VkDescriptorSetLayoutBinding> bindings(std::size_t(k.buffers));
  for (std::size_t i = 0; i < bindings.size(); ++i) {
    bindings[i] = {};
    bindings[i].binding = std::uint32_t(i);
    bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo l{};
  l.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  l.bindingCount = std::uint32_t(bindings.size());
  l.pBindings = bindings.data();
  vulkan_check(vkCreateDescriptorSetLayout(device, &l, nullptr, &k.set_layout),
               "creating the descriptors of " + name, "");
  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, std::uint32_t(k.buffers)};
  VkDescriptorPoolCreateInfo p{};
  p.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  p.maxSets = 1;
  p.poolSizeCount = 1;
  p.pPoolSizes = &size;
  vulkan_check(vkCreateDescriptorPool(device, &p, nullptr, &k.pool),
               "creating the descriptor pool of " + name, "");
  VkDescriptorSetAllocateInfo a{};
  a.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  a.descriptorPool = k.pool;
  a.descriptorSetCount = 1;
  a.pSetLayouts = &k.set_layout;
  vulkan_check(vkAllocateDescriptorSets(device, &a, &k.set),
               "allocating the descriptors of " + name, "");
}

void make_pipeline(VkDevice device, GpuKernel& k, const std::string& name) {
  const std::vector<std::uint32_t> words = spirv_words(name);
  VkShaderModuleCreateInfo m{};
  m.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  m.codeSize = words.size() * 4;
  m.pCode = words.data();
  vulkan_check(vkCreateShaderModule(device, &m, nullptr, &k.module), "loading " + name, "");
  const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, std::uint32_t(k.push_bytes)};
  VkPipelineLayoutCreateInfo l{};
  l.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  l.setLayoutCount = 1;
  l.pSetLayouts = &k.set_layout;
  l.pushConstantRangeCount = k.push_bytes ? 1 : 0;
  l.pPushConstantRanges = &push;
  vulkan_check(vkCreatePipelineLayout(device, &l, nullptr, &k.layout),
               "creating the layout of " + name, "");
  VkComputePipelineCreateInfo c{};
  c.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  c.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  c.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  c.stage.module = k.module;
  c.stage.pName = "main";
  c.layout = k.layout;
  vulkan_check(vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &c, nullptr, &k.pipeline),
               "compiling " + name, "");
}

}  // namespace

std::shared_ptr<GpuKernel> VulkanDevice::kernel(std::string_view name, int buffers,
                                                std::size_t push_bytes) {
  const std::lock_guard lock(mutex_);
  std::shared_ptr<GpuKernel>& k = kernels_[{std::string(name), buffers, push_bytes}];
  if (k) return k;
  auto made = std::make_shared<GpuKernel>(device_, buffers, push_bytes);
  const std::string n(name);
  make_descriptors(device_, *made, n);
  make_pipeline(device_, *made, n);
  k = std::move(made);
  return k;
}

void VulkanDevice::run(GpuKernel& k, std::span<GpuBuffer* const> buffers,
                       std::span<const std::byte> push, std::uint32_t groups_x,
                       std::uint32_t groups_y) {
  if (int(buffers.size()) != k.buffers || push.size() != k.push_bytes)
    throw Error(Error::Kind::kArgument, "a GPU kernel given the wrong buffers or constants");
  const std::lock_guard lock(mutex_);
  std::vector<VkDescriptorBufferInfo> infos(buffers.size());
  std::vector<VkWriteDescriptorSet> writes(buffers.size());
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    infos[i] = {buffers[i]->buffer, 0, VK_WHOLE_SIZE};
    writes[i] = {};
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = k.set;
    writes[i].dstBinding = std::uint32_t(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(device_, std::uint32_t(writes.size()), writes.data(), 0, nullptr);
  begin();
  vkCmdBindPipeline(commands_, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipeline);
  vkCmdBindDescriptorSets(commands_, VK_PIPELINE_BIND_POINT_COMPUTE, k.layout, 0, 1, &k.set, 0,
                          nullptr);
  if (!push.empty())
    vkCmdPushConstants(commands_, k.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0,
                       std::uint32_t(push.size()), push.data());
  vkCmdDispatch(commands_, groups_x, groups_y, 1);
  submit_and_wait("running a kernel");
}

}  // namespace detail
}  // namespace btfgmm
