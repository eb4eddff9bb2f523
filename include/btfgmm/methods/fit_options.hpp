// The options of a fit of any method (FitOptions, methods/representation.hpp) checked against
// the methods' declarations (methods/parameters.hpp) in one place, and the fit they ask for:
// shared by the command, the Python module, sweep and the budget, so that all fit the same
// model and refuse the same options with the same rule.
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
#include "btfgmm/methods/parameters.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/model/fit.hpp"

namespace btfgmm {

// The parameters every method takes (`method`, `tile`, the output, `seed`, `threads`), and
// those of the fit job a front end keeps (`output`, `overwrite`): the common rows beside each
// method's own (MethodInfo::parameters).
std::span<const FitParameter> common_fit_parameters();
// `method`'s declaration of `field` (its own, else the common one); null where it takes none.
const FitParameter* method_parameter(const MethodInfo& method, std::string_view field);
// Every field a fit takes, each once (its first declaration): the common ones, then each
// method's in the registry's order. What the front ends make their options of.
std::vector<const FitParameter*> fit_parameters();
// The first declaration of `field` (fit_parameters); null for a field no method takes.
const FitParameter* find_fit_parameter(std::string_view field);
// The declaration of `field` for a request of every method (a budget, a sweep): the common
// one, else the first method's that takes `route`, else the first; null for a field no method
// takes.
const FitParameter* route_parameter(std::string_view field, FitRoute route);
// The methods whose own declarations take `field` (none for a common one).
std::vector<std::string_view> methods_taking(std::string_view field);

// The help of `field` from its declarations: a common field's own sentence; else each
// method's, the methods with the same sentence and default together ("gm: mixture components
// M (default 600); pca-btf: eigen-images c (default 61); ..."). Options are named marked
// (option_name) for the front end to spell.
std::string parameter_help(std::string_view field);

// The fields `o` sets (a value other than FitOptions{}'s), in fit_parameters' order.
std::vector<std::string_view> given_fields(const FitOptions& o);

// The one check of a fit's options, for every front end and route: the fields `given` (those
// the front end was given, by field; `o` holds their values) against the declarations of
// `o.method` (kNew, kResume, kContinue) or of every method (kBudget, kSweep): a field the
// method does not take (the mixture's alone, or another method's), one that cannot apply with
// `route` (`source`: the checkpoint or model it goes on from, or the field of the budget), a
// value out of its range or choices (check_parameter_value), and the refinement's options with
// the objective likelihood. Throws Error(kArgument) naming the fields (option_name), with why
// and the fix. Each fit, sweep and budget checks its options once: fit_option_checks counts.
void check_fit_options(const FitOptions& o, std::span<const std::string_view> given, FitRoute route,
                       std::string_view source = {});
// How many times check_fit_options ran in this process.
std::uint64_t fit_option_checks();

// The device `o.device` names (empty: kAuto).
DeviceChoice fit_device(const FitOptions& o);

// The refinement's options of `o` in `config`: exactly refine_steps steps, or its bounds in
// seconds and epochs (set_refinement_bounds, model/fit.hpp, reads them). Throws
// Error(kArgument) for any of them given with an objective other than kPrediction (the
// paper's EM refines nothing; a continued fit's objective is its model's).
void set_refinement_options(FitConfig& config, const FitOptions& o);

// The mixture's fit job from `input` to `output` as `o` asks (checked by check_fit_options
// first; the tile, checkpoints and the stop flag are the caller's to set): M = 600, 40
// iterations, the prediction objective and the compact file unless given.
FitRequest mixture_fit_request(const FitOptions& o, const std::string& input,
                               const std::string& output);

// What a fit tells as it goes (the library prints nothing); any member may be empty.
struct FitProgress {
  std::function<void(const FitTile& tile)> started;    // the tile is read; the fit starts
  std::function<void(const EmProgress& p)> iteration;  // the mixture: after each EM iteration
  // The other methods; the mixture's refinement for the prediction ("refinement").
  std::function<void(double fraction, std::string_view stage)> progress;
  // Set: the fit stops (Error(kArgument), or null); a fit that keeps its best model met (the
  // neural BTF's) returns it, kStoppedSetting in its provenance (model/provenance.hpp).
  const std::atomic<bool>* stop = nullptr;
};

// Fits `o.method` to `tile` (empty: the whole image) of `source`, opened from `input`, and
// records the model's provenance as `btfgmm fit` does: the same data, options and seed give
// the model `btfgmm fit` writes, the provenance's times aside (docs/FORMAT.md). `o` is checked
// first, once, by its front end (check_fit_options, route kNew: before any work, such as
// opening the data, is done). The mixture's fit stopped by `progress.stop` during EM returns
// null; during its refinement for the prediction, the model of the lowest error met
// (complete). Throws Error as the loading and the fit do.
std::unique_ptr<Representation> fit_representation(const FitOptions& o, const std::string& input,
                                                   std::shared_ptr<const BtfSource> source,
                                                   const Tile& tile,
                                                   const FitProgress& progress = {});

}  // namespace btfgmm
