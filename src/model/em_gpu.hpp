// The E pass of the grid EM on a compute device (docs/GPU.md): the same numbers as em.cpp's
// e_pass, Eq. (2)-(4) and the sums of the M-step, summed by the shaders of src/gpu/shaders
// (em_normaliser.comp, em_statistics.comp, em_light_sums.comp) from the CPU's tables of the
// iteration (em_tables.cpp), and assembled per light by the one light_statistics.
#pragma once

#include <memory>
#include <vector>

#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/samples.hpp"
#include "model/em_group_pass.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

class GpuEPass {
 public:
  // Holds the residual colours of the lights `s` holds on `device` for every pass that
  // follows. Throws Error(kArgument) where the device cannot hold them (the bytes needed and
  // the device's), before any transfer.
  GpuEPass(ComputeDevice& device, const SampleSet& s);
  ~GpuEPass();
  GpuEPass(const GpuEPass&) = delete;
  GpuEPass& operator=(const GpuEPass&) = delete;

  // One E pass with the tables `t` of `mix`: each held light's numbers as e_pass returns them
  // (light_statistics; with `stats` false, L's terms alone).
  std::vector<std::vector<double>> run(const Tables& t, const ProductMixture& mix,
                                       const Periods& periods, bool stats);

  // Where the passes' time went so far, seconds (wall clock): the tables uploaded, the
  // normaliser, the statistics (with the light sums) and the host's downloads and assembly.
  struct Seconds {
    double upload = 0.0, normaliser = 0.0, statistics = 0.0, host = 0.0;
  };
  const Seconds& seconds() const;

  // The device memory a pass over `s` with `components` columns takes, bytes.
  static double device_bytes(const SampleSet& s, std::size_t components);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace btfgmm::detail
