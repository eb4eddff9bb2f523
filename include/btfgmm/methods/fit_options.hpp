// The settings of a fit of any method as `btfgmm fit` takes them, the one table of which method
// takes which of them (with their ranges), and the fit they ask for: one place for the
// defaults (the mixture's: FitConfig and EmConfig, model/fit.hpp; the prediction objective and
// the compact file; each method's own) and for the checks, shared by the command and the
// Python module, so that both fit the same model and refuse the same options.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

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
  int refine_epochs = 0;  // gm, prediction: its bound in passes over the data (0: none but 1000)
  std::string device;     // gm: where EM runs, "auto" (default: a GPU where one exists), "cpu",
                          // "gpu" (docs/GPU.md)
};

// The device `o.device` names (empty: kAuto). Throws Error(kArgument) for any other word.
DeviceChoice fit_device(const FitOptions& o);

// What a fit request does: a new fit, an interrupted mixture's fit resumed from its
// checkpoint, a finished mixture continued, or the method and size chosen within a budget.
enum class FitRoute : unsigned { kNew = 1, kResume = 2, kContinue = 4, kBudget = 8 };
constexpr unsigned operator|(FitRoute a, FitRoute b) {
  return unsigned(a) | unsigned(b);
}
constexpr unsigned operator|(unsigned a, FitRoute b) {
  return a | unsigned(b);
}

// One option of the fit: which methods take it, with which routes it may be given, and its
// range. Messages name it by `field` (core/text.hpp, option_name), the FitOptions field or,
// for the options of the command's fit alone (checkpoints, the log, the output), their name.
struct FitOptionRule {
  std::string_view field;
  std::string_view methods;     // the methods that take it, by name, separated by spaces; "all"
  unsigned routes = 0;          // the FitRoutes it may be given with
  double min = 0.0, max = 0.0;  // its range; min == max: none (text, or any number)
  bool takes(std::string_view method) const;
  bool has_range() const { return min < max; }
};

// Every option of the fit, in the order messages list them. A new option adds a row; a new
// method adds its name to the rows it takes.
std::span<const FitOptionRule> fit_option_rules();
// The row of `field`; asserts that there is one.
const FitOptionRule& fit_option_rule(std::string_view field);

// The fields of the options `o` sets (a value other than its default).
std::vector<std::string_view> given_fields(const FitOptions& o);

// The one check of the options given (by field) against the table: those that cannot apply
// with `route` (`source`: the checkpoint or model it goes on from, or the field of the budget
// given) and those of the Gaussian mixture's fit alone given to another `method`. Throws
// Error(kArgument) naming every such option (option_name), with why and the fix.
void check_fit_options(std::span<const std::string_view> given, std::string_view method,
                       FitRoute route, std::string_view source = {});

// config.refinement_steps = steps (0: as many as the fit affords). Throws Error(kArgument)
// for steps outside 0..kMaxRefineSteps, and for steps with an objective other than kPrediction.
void set_refine_steps(FitConfig& config, int steps);
// Throws Error(kArgument) for a bound given (not 0) outside its range (a NaN included) or with
// an objective other than kPrediction (the paper's EM refines nothing).
void check_refine_bounds(double seconds, int epochs, FitObjective objective);
// The refinement's bounds where given (> 0): config.refinement_seconds = seconds,
// config.refinement_epochs = epochs. Throws Error(kArgument) for either given with an
// objective other than kPrediction (the paper's EM refines nothing) or outside its range.
void set_refine_bounds(FitConfig& config, double seconds, int epochs);

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
