// The gradient passes of the fit for the prediction on a compute device (docs/GPU.md): the
// same error and gradient as GradientPass (refine_gradient.cpp, Eq. 8-11) over the samples of
// a selection, every component of every sample weighed, summed by the shaders of
// src/gpu/shaders (refine_tables.comp, refine_errors.comp, refine_statistics.comp,
// refine_normal.comp, em_light_sums.comp) and folded
// light by light on the host in light order, as the CPU's passes fold them.
#pragma once

#include <memory>

#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/refine_internal.hpp"

namespace btfgmm::detail {

class GpuPredictionPass final : public PredictionPass {
 public:
  // Holds the residual colours of the lights `s` holds, and which are held out, on `device`
  // for every pass that follows. Throws Error(kArgument) where the device cannot hold them
  // with M = `components` (the bytes needed and the device's), before any transfer.
  GpuPredictionPass(ComputeDevice& device, const SampleSet& s, std::size_t components);
  ~GpuPredictionPass() override;
  GpuPredictionPass(const GpuPredictionPass&) = delete;
  GpuPredictionPass& operator=(const GpuPredictionPass&) = delete;

  PredictionGradient operator()(const ProductMixture& mix, const Selection& selection,
                                bool gradient = true) override;
  // G and b summed on the device (refine_normal.comp) in float over 256 samples at a time,
  // then in double; every component of every sample weighed; the energy on the host.
  ColourNormalEquations normal_equations(const ProductMixture& mix, std::size_t stride,
                                         const std::atomic<bool>* stop,
                                         const std::function<void(double)>& progress) override;

  // The device memory the passes over `s` with `components` components take, bytes.
  static double device_bytes(const SampleSet& s, std::size_t components);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace btfgmm::detail
