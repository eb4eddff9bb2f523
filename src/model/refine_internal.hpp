// What the fit for the prediction shares between its colour refit (refine.cpp) and its
// gradient passes (refine_gradient.cpp): which samples are held out for validation, which
// enter a minibatch, and the sums over lights folded in one fixed order on any number of
// processes and threads.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/core/communicator.hpp"
#include "btfgmm/gpu/compute_device.hpp"
#include "btfgmm/model/refine.hpp"

namespace btfgmm::detail {

// The stride (GridWeights::kept) that takes about `wanted` of `samples` samples: at least
// `wanted`, fewer than twice as many (all of them when there are fewer).
inline std::size_t subsample_stride(std::size_t samples, std::size_t wanted) {
  return std::max<std::size_t>(1, samples / std::max<std::size_t>(wanted, 1));
}

// SplitMix64's finaliser (Steele, Lea & Flood 2014): a well-mixed hash of an index.
inline std::uint64_t mix_bits(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Whether sample (pixel p, (light, view) pair j = l nv + v of the whole tile) is held out for
// validation: 1 in kValidationEvery of pixels x directions, by a hash of its place in the tile
// (the same on any number of processes; validation_sample in refine.hpp).
inline bool held_out(std::size_t p, std::size_t j, std::size_t pairs) {
  return validation_sample(p, j, pairs);
}

// The samples a pass takes: those of pixel p and pair j with (p + j) mod `modulus` =
// `residue` (a systematic subsample: every image keeps every modulus-th pixel), and of those
// the training samples, the validation samples, or all.
struct Selection {
  enum class Part { kAll, kTraining, kValidation };
  std::size_t modulus = 1, residue = 0;
  Part part = Part::kAll;
  bool takes(std::size_t p, std::size_t j, std::size_t pairs) const {
    if ((p + j) % modulus != residue) return false;
    if (part == Part::kAll) return true;
    return held_out(p, j, pairs) == (part == Part::kValidation);
  }
};

// The totals of sums taken light by light over the lights of every process, folded in light
// order: total = (((0 + s_0) + s_1) + ...) whichever process holds which lights, so that 1, 2
// or 3 processes (and any number of threads) give the same totals bit for bit. fold_own(total)
// adds this process's lights, in order, to `total` (n values). Over several processes they
// take turns in rank order, each from the totals of those before it (one exchange a process).
template <class FoldOwn>
std::vector<double> fold_over_processes(Communicator* processes, std::size_t n,
                                        FoldOwn&& fold_own) {
  std::vector<double> total(n, 0.0);
  if (!processes || processes->size() == 1) {
    fold_own(total);
    return total;
  }
  for (int turn = 0; turn < processes->size(); ++turn) {
    std::vector<double> mine;
    if (turn == processes->rank()) {
      fold_own(total);
      mine = total;
    }
    auto all = all_gather_values<double>(*processes, std::span<const double>(mine));
    total = std::move(all[std::size_t(turn)]);
  }
  return total;
}

// Whether any process asks (true in one asks all); one exchange over several processes.
bool any_process(Communicator* processes, bool mine);

// A pass of the prediction's squared error (Eq. 8-11), and with `gradient` its gradient, over
// the samples of a selection: the CPU's (SparsePass, refine_pass.hpp) or a compute device's
// (GpuPredictionPass, refine_gpu.hpp), the same numbers but for the order of float sums.
class PredictionPass {
 public:
  virtual ~PredictionPass() = default;
  virtual PredictionGradient operator()(const ProductMixture& mix, const Selection& selection,
                                        bool gradient = true) = 0;
  // The normal equations of the colour means' refit (colour_normal_equations) over the
  // training samples of the subsample `stride`. A set `stop` may end them early (they are
  // then of no use); `progress` is told how far they are.
  virtual ColourNormalEquations normal_equations(const ProductMixture& mix, std::size_t stride,
                                                 const std::atomic<bool>* stop,
                                                 const std::function<void(double)>& progress) = 0;
};

// The pass on `device`, or on the CPU's `threads` where it is null, for mixtures of `m`
// components. Throws Error(kArgument) where the device cannot hold the samples.
std::unique_ptr<PredictionPass> make_prediction_pass(const SampleSet& samples, std::size_t m,
                                                     int threads, ComputeDevice* device);

// From a mixture whose colour means were just refitted: the Adam epochs of `config` over the
// training samples, the colour refit after them; the parameters of the lowest validation
// error met are kept in `mix`. Fills `out` (steps, epochs, errors, stopped).
void gradient_epochs(const SampleSet& samples, ProductMixture& mix, PredictionPass& pass,
                     const GradientConfig& config, PredictionRefinement& out);

// The seconds of one Adam step's gradient pass over a minibatch of about `batch` training
// samples and of one validation (timed on an eighth of the held-out samples, scaled), on
// `mix`; the minibatches of an epoch.
struct StepTimes {
  double step = 0.0, validation = 0.0;
  std::size_t batches = 0, validate_every = 0;
};
StepTimes time_gradient_step(const SampleSet& samples, const ProductMixture& mix,
                             PredictionPass& pass, std::size_t batch);

// The squared error of the prediction over the samples of `selection` (float pass), and
// their count.
std::pair<double, std::size_t> selection_error(const SampleSet& samples, const ProductMixture& mix,
                                               int threads, const Selection& selection);
std::pair<double, std::size_t> selection_error(PredictionPass& pass, const ProductMixture& mix,
                                               const Selection& selection);

}  // namespace btfgmm::detail
