// What the model's passes on a compute device share (em_gpu.cpp, refine_gpu.cpp): how a
// light's pixels are cut into chunks, push constants as bytes, workgroup counts within
// Vulkan's least limits, and the sums of chunks in chunk order (em_light_sums.comp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/model/mixture.hpp"
#include "model/conditional.hpp"

namespace btfgmm::detail {

constexpr std::uint32_t kSumGroup = 256;      // em_light_sums.comp's local size
constexpr std::uint32_t kMaxGroupsX = 65535;  // Vulkan's least maxComputeWorkGroupCount

// A light's pixels are cut into chunks as the CPU's E pass cuts them (em.cpp, chunk_count).
inline std::uint32_t gpu_chunks(std::size_t pixels) {
  return std::uint32_t(std::clamp<std::size_t>((pixels + 255) / 256, 1, 16));
}

// The iterations of the statistics shaders' loop nests (em_statistics.comp,
// refine_statistics.comp) in one workgroup: four pixels of a chunk at a time, each with its
// `per_pixel` samples, read in tiles of at most 64 (a loop of its own, and one to load each).
inline std::size_t statistics_iterations(std::size_t pixels, std::size_t per_pixel) {
  const std::size_t chunk = (pixels + gpu_chunks(pixels) - 1) / gpu_chunks(pixels);
  return (chunk + 3) / 4 * (per_pixel + 2 * ((per_pixel + 63) / 64) + 1) + 64;
}

template <typename T>
std::span<const std::byte> bytes_of(const T& value) {
  return std::as_bytes(std::span(&value, 1));
}

// A buffer on `device` holding `values` (room for at least 4, so that an empty one binds).
inline std::shared_ptr<GpuBuffer> uploaded(ComputeDevice& device, std::span<const float> values) {
  auto b = device.buffer(std::max<std::size_t>(values.size(), 4) * sizeof(float));
  device.upload_values<float>(*b, values);
  return b;
}

// Enough workgroups of `size` for `n` invocations, as (x, y) within Vulkan's least limits.
inline std::pair<std::uint32_t, std::uint32_t> groups_for(std::size_t n, std::uint32_t size) {
  const auto groups = std::uint32_t((n + size - 1) / size);
  const std::uint32_t gx = std::max<std::uint32_t>(1, std::min(groups, kMaxGroupsX));
  return {gx, (groups + gx - 1) / gx};
}

// `to`[g][i] = the sum over c, in order, of `from`[g][c][i], for i < per_chunk, c < chunks,
// g < groups, by em_light_sums.comp (`kernel`).
inline void sum_chunks(ComputeDevice& device, GpuKernel& kernel, GpuBuffer& from, GpuBuffer& to,
                       std::size_t per_chunk, std::size_t chunks, std::size_t groups) {
  struct Push {
    std::uint32_t per_chunk, chunks, held;
  };
  const Push push{std::uint32_t(per_chunk), std::uint32_t(chunks), std::uint32_t(groups)};
  GpuBuffer* bound[] = {&from, &to};
  device.run(kernel, bound, bytes_of(push), std::uint32_t((per_chunk + kSumGroup - 1) / kSumGroup),
             push.held);
}

// Each component's parameters as refine_tables.comp and predict_colours.comp read them, 5 vec4:
// (mu_6..8, 0), (mu_0, mu_1, 1/sigma^2_0, 1/sigma^2_1), the same of the view's angles (inputs
// 4, 5), the same of the light's (inputs 2, 3), (log_weight_base, 0, 0, 0).
constexpr std::size_t kComponentVectors = 5;
inline std::vector<float> component_vectors(const ProductMixture& mix) {
  std::vector<float> c(kComponentVectors * 4 * mix.size(), 0.0f);
  for (std::size_t k = 0; k < mix.size(); ++k) {
    const auto &mu = mix.mean[k], &var = mix.var[k];
    float* at = &c[kComponentVectors * 4 * k];
    for (std::size_t ch = 0; ch < 3; ++ch) at[ch] = float(mu[6 + ch]);
    const std::size_t pairs[3] = {0, 4, 2};
    for (std::size_t q = 0; q < 3; ++q)
      for (std::size_t n = 0; n < 2; ++n) {
        at[4 * (1 + q) + n] = float(mu[pairs[q] + n]);
        at[4 * (1 + q) + 2 + n] = float(1.0 / var[pairs[q] + n]);
      }
    at[16] = float(log_weight_base(mix, k));
  }
  return c;
}

// The light sums' kernel, as sum_chunks runs it.
inline std::shared_ptr<GpuKernel> chunk_sums_kernel(ComputeDevice& device) {
  return device.kernel("em_light_sums.spv", 2, 3 * sizeof(std::uint32_t));
}

}  // namespace btfgmm::detail
