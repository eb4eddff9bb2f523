// The settings of a fit of any method, with their defaults, and the fit they ask for.
#include "btfgmm/methods/fit_options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {
namespace {

constexpr unsigned kAnyRoute =
    FitRoute::kNew | FitRoute::kResume | FitRoute::kContinue | FitRoute::kBudget;
constexpr unsigned kMixtureRoutes = FitRoute::kNew | FitRoute::kResume | FitRoute::kContinue;
constexpr double kMaxSize = 100000;

// Which method takes which option of the fit, and its range (fit_options.hpp). Each method
// checks the sizes it takes against the tile itself (its message names the range the tile
// allows), and refuses the other methods' sizes; check_fit_options refuses what cannot apply
// with a request and the mixture's options given to another method.
constexpr FitOptionRule kRules[] = {
    {.field = "output",
     .methods = "all",
     .routes = FitRoute::kNew | FitRoute::kContinue | FitRoute::kBudget},
    {.field = "method", .methods = "all", .routes = unsigned(FitRoute::kNew)},
    {.field = "tile", .methods = "all", .routes = FitRoute::kNew | FitRoute::kBudget},
    {.field = "components",
     .methods = "gm pca-btf pca-rf lpca",
     .routes = unsigned(FitRoute::kNew),
     .min = 1,
     .max = kMaxSize},
    {.field = "clusters",
     .methods = "lpca 3d-car 2d-car gmrf",
     .routes = unsigned(FitRoute::kNew),
     .min = 1,
     .max = kMaxSize},
    {.field = "degree",
     .methods = "plm-rf",
     .routes = unsigned(FitRoute::kNew),
     .min = 0,
     .max = 64},
    {.field = "seed", .methods = "all", .routes = FitRoute::kNew | FitRoute::kBudget},
    {.field = "precision", .methods = "all", .routes = unsigned(FitRoute::kNew)},
    {.field = "overwrite",
     .methods = "all",
     .routes = FitRoute::kNew | FitRoute::kContinue | FitRoute::kBudget},
    {.field = "objective", .methods = "gm", .routes = FitRoute::kNew | FitRoute::kResume},
    {.field = "refine_steps",
     .methods = "gm",
     .routes = kMixtureRoutes,
     .min = 1,
     .max = kMaxRefineSteps},
    {.field = "refine_seconds",
     .methods = "gm",
     .routes = kMixtureRoutes | FitRoute::kBudget,
     .min = 1,
     .max = kMaxRefineSeconds},
    {.field = "refine_epochs",
     .methods = "gm",
     .routes = kMixtureRoutes | FitRoute::kBudget,
     .min = 1,
     .max = kMaxRefineEpochs},
    {.field = "epsilon", .methods = "gm", .routes = kMixtureRoutes, .min = 0, .max = 1},
    {.field = "iterations",
     .methods = "gm lpca plm-rf",
     .routes = kAnyRoute,
     .min = 1,
     .max = kMaxSize},
    {.field = "levels",
     .methods = "3d-car 2d-car gmrf",
     .routes = unsigned(FitRoute::kNew),
     .min = 1,
     .max = 16},
    {.field = "checkpoint", .methods = "gm", .routes = kMixtureRoutes},
    {.field = "checkpoint_every",
     .methods = "gm",
     .routes = kMixtureRoutes,
     .min = 1,
     .max = kMaxSize},
    {.field = "resume", .methods = "gm", .routes = unsigned(FitRoute::kResume)},
    {.field = "continue", .methods = "gm", .routes = unsigned(FitRoute::kContinue)},
    {.field = "log", .methods = "gm", .routes = kMixtureRoutes},
    {.field = "threads", .methods = "all", .routes = kAnyRoute, .min = 0, .max = 1024},
    {.field = "device", .methods = "gm", .routes = kMixtureRoutes},
};

// "`a`", "`a`, `b`", ... of the fields, and "it" or "them".
std::string named_fields(std::span<const std::string_view> fields) {
  std::string named;
  for (const std::string_view f : fields) named += (named.empty() ? "" : ", ") + option_name(f);
  return named;
}
const char* it_or_them(std::span<const std::string_view> fields) {
  return fields.size() == 1 ? "it" : "them";
}

// The fields of `given` whose row refuses them: in the table's order.
template <typename Refused>
std::vector<std::string_view> refused_fields(std::span<const std::string_view> given,
                                             Refused refused) {
  std::vector<std::string_view> out;
  for (const FitOptionRule& r : kRules)
    if (std::find(given.begin(), given.end(), r.field) != given.end() && refused(r))
      out.push_back(r.field);
  return out;
}

// Why options cannot apply with `route`.
std::string route_reason(FitRoute route, std::string_view source) {
  switch (route) {
    case FitRoute::kResume:
      return fmt::format(
          "with {}: the fit goes on with the input, tile, components, seed, "
          "precision and output its checkpoint '{}' holds",
          option_name("resume"), source);
    case FitRoute::kContinue:
      return fmt::format(
          "with {}: the fit goes on with the tile, components, seed, precision "
          "and objective of the model '{}'",
          option_name("continue"), source);
    case FitRoute::kBudget:
      return fmt::format(
          "with {}: it chooses the method and size itself (each method's largest "
          "size whose file fits, stored as fit stores it)",
          option_name(source));
    case FitRoute::kNew:
      break;
  }
  return {};
}

// The mixture's file: compact unless asked (its own encodings; the registry's fit_encoding is
// the other methods').
Precision mixture_precision(const std::string& text) {
  if (text.empty() || text == "compact" || text == "q8") return Precision::kCompact;
  if (text == "f32") return Precision::kF32;
  if (text == "f16") return Precision::kF16;
  throw Error(Error::Kind::kArgument,
              fmt::format("{} '{}': the Gaussian mixture stores compact (the default: "
                          "quantised, zstd), f32 or f16",
                          option_name("precision"), text));
}

// The mixture, as run_fit fits it but for the file.
std::unique_ptr<Representation> fit_mixture(const FitOptions& o, const std::string& input,
                                            std::shared_ptr<const BtfSource> source,
                                            const Tile& tile, const FitProgress& progress) {
  FitRequest r = mixture_fit_request(o, input, "");
  r.tile = tile;
  r.source = std::move(source);
  r.config.em.stop = progress.stop;
  FitObserver observer;
  observer.started = progress.started;
  observer.iteration = progress.iteration;
  if (progress.progress)
    observer.refinement = [&progress](const GradientProgress& g) {
      progress.progress(g.fraction, g.colour_refit ? "colour refit" : "refinement");
    };
  FitOutcome fit = fit_in_memory(r, observer);
  if (fit.interrupted) return nullptr;
  return std::make_unique<GaussianMixture>(std::move(fit.model));
}

// A new fit of another method than the mixture refuses the options its method does not take,
// naming the methods that take each (`levels` has its own message, in method_settings; the
// mixture's refusals of `clusters` and `degree` are mixture_fit_request's).
void refuse_options_not_taken(std::span<const std::string_view> given, std::string_view method,
                              FitRoute route) {
  if (route != FitRoute::kNew || method == kMixtureMethod) return;
  const std::vector<std::string_view> not_taken =
      refused_fields(given, [method](const FitOptionRule& r) {
        return r.methods != kMixtureMethod && r.field != "levels" && !r.takes(method);
      });
  if (not_taken.empty()) return;
  std::string takers;
  for (const std::string_view f : not_taken)
    takers += fmt::format("{}{} is taken by {}", takers.empty() ? "" : "; ", option_name(f),
                          fit_option_rule(f).methods);
  throw Error(Error::Kind::kArgument,
              fmt::format("{} cannot apply to {} {}, which does not take {} ({}); leave {} out",
                          named_fields(not_taken), option_name("method"), method,
                          it_or_them(not_taken), takers, it_or_them(not_taken)));
}

}  // namespace

bool FitOptionRule::takes(std::string_view method) const {
  if (methods == "all") return true;
  for (std::size_t at = 0; at < methods.size();) {
    const std::size_t end = std::min(methods.find(' ', at), methods.size());
    if (methods.substr(at, end - at) == method) return true;
    at = end + 1;
  }
  return false;
}

std::span<const FitOptionRule> fit_option_rules() {
  return kRules;
}

const FitOptionRule& fit_option_rule(std::string_view field) {
  for (const FitOptionRule& r : kRules)
    if (r.field == field) return r;
  assert(false && "no such option of the fit");
  return kRules[0];
}

std::vector<std::string_view> given_fields(const FitOptions& o) {
  const std::pair<std::string_view, bool> set[] = {
      {"method", o.method != kMixtureMethod},
      {"components", o.components != 0},
      {"clusters", o.clusters != 0},
      {"degree", o.degree != 0},
      {"iterations", o.iterations != 0},
      {"levels", o.levels != 0},
      {"epsilon", o.epsilon.has_value()},
      {"precision", !o.precision.empty()},
      {"objective", !o.objective.empty()},
      {"refine_steps", o.refine_steps != 0},
      {"refine_seconds", o.refine_seconds != 0},
      {"refine_epochs", o.refine_epochs != 0},
      {"device", !o.device.empty()},
  };
  std::vector<std::string_view> out;
  for (const auto& [field, given] : set)
    if (given) out.push_back(field);
  return out;
}

void check_fit_options(std::span<const std::string_view> given, std::string_view method,
                       FitRoute route, std::string_view source) {
  const std::vector<std::string_view> mixture_only =
      route == FitRoute::kBudget ? std::vector<std::string_view>()
                                 : refused_fields(given, [method](const FitOptionRule& r) {
                                     return r.methods == kMixtureMethod && !r.takes(method);
                                   });
  if (!mixture_only.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} cannot apply to {} {}: they belong to the Gaussian mixture's fit "
                            "({} gm) only; leave {} out",
                            named_fields(mixture_only), option_name("method"), method,
                            option_name("method"), it_or_them(mixture_only)));
  refuse_options_not_taken(given, method, route);
  const std::vector<std::string_view> off_route = refused_fields(
      given, [route](const FitOptionRule& r) { return (r.routes & unsigned(route)) == 0; });
  if (!off_route.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} cannot apply {}; leave {} out", named_fields(off_route),
                            route_reason(route, source), it_or_them(off_route)));
}

void set_refine_steps(FitConfig& config, int steps) {
  const FitOptionRule& rule = fit_option_rule("refine_steps");
  if (steps < 0 || steps > rule.max)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} {}: give {} to {} Adam steps, or leave it out for as many as the "
                            "fit affords",
                            option_name(rule.field), steps, rule.min, rule.max));
  if (steps > 0 && config.objective != FitObjective::kPrediction)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} applies to the objective prediction only (the paper's EM, {} "
                            "likelihood, refines nothing); leave one of them out",
                            option_name(rule.field), option_name("objective")));
  config.refinement_steps = steps;
}

void check_refine_bounds(double seconds, int epochs, FitObjective objective) {
  const std::pair<std::string_view, bool> given[] = {{"refine_seconds", seconds != 0},
                                                     {"refine_epochs", epochs != 0}};
  for (const auto& [field, set] : given) {
    const FitOptionRule& rule = fit_option_rule(field);
    const double value = field == "refine_epochs" ? double(epochs) : seconds;
    if (set && !(value >= rule.min && value <= rule.max))
      throw Error(
          Error::Kind::kArgument,
          fmt::format("{} {:g}: give {:g} to {:g}", option_name(field), value, rule.min, rule.max));
    if (set && objective != FitObjective::kPrediction)
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} applies to the objective prediction only (the paper's EM, {} "
                              "likelihood, refines nothing); leave one of them out",
                              option_name(field), option_name("objective")));
  }
}

void set_refine_bounds(FitConfig& config, double seconds, int epochs) {
  check_refine_bounds(seconds, epochs, config.objective);
  if (seconds > 0) config.refinement_seconds = seconds;
  if (epochs > 0) config.refinement_epochs = epochs;
}

FitRequest mixture_fit_request(const FitOptions& o, const std::string& input,
                               const std::string& output) {
  if (o.clusters != 0 || o.degree != 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} applies to {} {} only, not to the Gaussian mixture; leave it out",
                            option_name(o.clusters ? "clusters" : "degree"), option_name("method"),
                            o.clusters ? "lpca" : "plm-rf"));
  if (o.levels != 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} applies to the pyramid of {} 3d-car, 2d-car or gmrf only, not "
                            "to the Gaussian mixture; leave it out",
                            option_name("levels"), option_name("method")));
  const std::vector<std::string_view> given = given_fields(o);
  check_fit_options(given, kMixtureMethod, FitRoute::kNew);
  FitRequest r;
  r.input = input;
  r.output = output;
  r.config = mixture_config(o.components, o.iterations, o.seed, o.threads);
  r.config.em.epsilon = o.epsilon.value_or(0.0);
  r.config.objective =
      parse_objective(o.objective.empty() ? "prediction" : o.objective, option_name("objective"));
  set_refine_steps(r.config, o.refine_steps);
  set_refine_bounds(r.config, o.refine_seconds, o.refine_epochs);
  r.precision = mixture_precision(o.precision);
  r.config.device = fit_device(o);
  return r;
}

DeviceChoice fit_device(const FitOptions& o) {
  if (o.device.empty()) return DeviceChoice::kAuto;
  if (const auto choice = parse_device_choice(o.device)) return *choice;
  throw Error(Error::Kind::kArgument,
              fmt::format("{} '{}' is not a device: give auto (a GPU where one exists, else the "
                          "CPU), cpu or gpu",
                          option_name("device"), o.device));
}

MethodSettings method_settings(const FitOptions& o, const MethodInfo& method) {
  const std::vector<std::string_view> given = given_fields(o);
  check_fit_options(given, method.name, FitRoute::kNew);
  if (o.levels != 0 && !fit_option_rule("levels").takes(method.name))
    throw Error(Error::Kind::kArgument,
                fmt::format("{} {} cannot apply to {} {}: it has no pyramid ({} applies to "
                            "3d-car, 2d-car and gmrf); leave it out",
                            option_name("levels"), o.levels, option_name("method"), method.name,
                            option_name("levels")));
  MethodSettings s;
  s.components = o.components;
  s.levels = o.levels;
  s.clusters = o.clusters;
  s.degree = o.degree;
  s.iterations = o.iterations;
  s.seed = o.seed;
  s.threads = o.threads;
  // The method's default file (default_file_encoding; compact for the factor methods, at most
  // 0.06 dB below q8 on generated tiles, docs/METHODS.md), the one sweep and the budget measure.
  s.encoding = o.precision.empty() ? default_file_encoding(method)
                                   : parse_factor_encoding(o.precision, option_name("precision"));
  return s;
}

std::unique_ptr<Representation> fit_representation(const FitOptions& o, const std::string& input,
                                                   std::shared_ptr<const BtfSource> source,
                                                   const Tile& tile, const FitProgress& progress) {
  if (o.method == kMixtureMethod) return fit_mixture(o, input, std::move(source), tile, progress);
  const MethodInfo& method = find_method(o.method);
  MethodSettings s = method_settings(o, method);
  s.progress = progress.progress;
  s.stop = progress.stop;
  if (!source) source = std::make_shared<const BtfSource>(BtfSource::open(input));
  const BtfInfo& info = source->info();
  const Btf btf = source->load(tile.or_whole(info.width, info.height));
  if (progress.started)
    progress.started(FitTile{.lights = btf.lights(),
                             .views = btf.views(),
                             .origin = btf.origin(),
                             .format = btf.format()});
  return fit_and_record(method, btf, s, fingerprint_of(btf, {input, info.width, info.height}));
}

}  // namespace btfgmm
