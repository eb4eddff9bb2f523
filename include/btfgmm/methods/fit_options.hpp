// The settings of a fit of any method as `btfgmm fit` takes them, and the fit they ask for: one
// place for the defaults (the mixture's M = 600, 40 iterations, the prediction objective, the
// compact file; each method's own) that
// the command and the Python module share, so that both fit the same model.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/model/fit.hpp"

namespace btfgmm {

// A size or count left at 0 and a text left empty take the method's default.
struct FitOptions {
  std::string method = "gm";
  std::size_t components = 0, clusters = 0, degree = 0;
  int iterations = 0;
  int levels = 0;                 // 3d-car, 2d-car, gmrf: Gaussian-Laplacian pyramid levels
  std::optional<double> epsilon;  // the mixture's EM only (default 0: all iterations)
  std::uint64_t seed = 1;
  int threads = 0;        // 0: OpenMP's default; the model does not depend on it
  std::string precision;  // gm: "compact" (default; "q8" too), "f32" or "f16"; others: "q8"
                          // (default), "f32", "f16"
  std::string objective;  // gm: "prediction" (default) or "likelihood" (the paper's EM alone)
  int refine_steps = 0;   // gm, prediction: the refinement's Adam steps (0: its stopping rule)
  double refine_seconds = 0.0;  // gm, prediction: its bound on time (0: default_refine_seconds)
};

// config.refinement_steps = steps (0: as many as the fit affords). Throws Error(kArgument)
// for steps outside 0..kMaxRefineSteps, and for steps with an objective other than kPrediction.
void set_refine_steps(FitConfig& config, int steps);

// The mixture's fit job from `input` to `output` (the tile, checkpoints and the stop flag are
// the caller's to set): M = 600, 40 iterations, the prediction objective and the compact file
// unless given. Throws Error(kArgument) for a precision other than compact (q8), f32 or f16, an
// unknown objective, refinement steps with the likelihood objective, and for clusters, degree
// or levels (other methods' sizes).
FitRequest mixture_fit_request(const FitOptions& o, const std::string& input,
                               const std::string& output);

// Another method's settings: the sizes as given, the method's own storage unless a precision
// is given. Throws Error(kArgument) for an epsilon, an objective or refinement steps (the
// mixture's alone), levels
// for a method without a pyramid, and a precision that does not parse.
MethodSettings method_settings(const FitOptions& o, const MethodInfo& method);

// What a fit tells as it goes (the library prints nothing); any member may be empty.
struct FitProgress {
  std::function<void(const FitTile& tile)> started;    // the tile is read; the fit starts
  std::function<void(const EmProgress& p)> iteration;  // the mixture: after each EM iteration
  // The other methods; the mixture's refinement for the prediction ("refinement").
  std::function<void(double fraction, std::string_view stage)> progress;
  const std::atomic<bool>* stop = nullptr;  // set: the fit stops (Error(kArgument), or null)
};

// Fits `o.method` to `tile` (empty: the whole image) of `source`, opened from `input`, and
// records the model's provenance as `btfgmm fit` does: the same data, options and seed give
// the model `btfgmm fit` writes, the provenance's times aside (docs/FORMAT.md). The mixture's
// fit stopped by `progress.stop` during EM returns null; during its refinement for the
// prediction, the model of the lowest error met (complete). Throws Error as the options, the
// loading and the fit do.
std::unique_ptr<Representation> fit_representation(const FitOptions& o, const std::string& input,
                                                   std::shared_ptr<const BtfSource> source,
                                                   const Tile& tile,
                                                   const FitProgress& progress = {});

}  // namespace btfgmm
