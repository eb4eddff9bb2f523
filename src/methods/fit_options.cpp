// The options of a fit of any method checked in one place, and the fit they ask for.
#include "btfgmm/methods/fit_options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {
namespace {

using T = ParameterType;
constexpr unsigned kAnyRoute =
    FitRoute::kNew | FitRoute::kResume | FitRoute::kContinue | FitRoute::kBudget | FitRoute::kSweep;

// The rows every method takes. `output` and `overwrite` are the fit job's (no member).
constexpr FitParameter kCommonParameters[] = {
    {.field = "method",
     .type = T::kText,
     .member = &FitOptions::method,
     .default_text = "gm",
     .routes = unsigned(FitRoute::kNew),
     .help = "the representation to fit"},
    {.field = "tile", .type = T::kText, .routes = FitRoute::kNew | FitRoute::kBudget},
    {.field = "seed",
     .type = T::kCount,
     .member = &FitOptions::seed,
     .min = 0,
     .max = 9.2e18,
     .default_text = "1",
     .routes = FitRoute::kNew | FitRoute::kBudget | FitRoute::kSweep,
     .help = "the seed of the fit's random start (equal seeds give equal models)"},
    {.field = "threads",
     .type = T::kInteger,
     .member = &FitOptions::threads,
     .min = 0,
     .max = 1024,
     .default_text = "0",
     .routes = kAnyRoute,
     .help = "threads (0: all cores; the model does not depend on it)"},
    {.field = "output",
     .type = T::kText,
     .routes = FitRoute::kNew | FitRoute::kContinue | FitRoute::kBudget},
    {.field = "overwrite",
     .type = T::kFlag,
     .routes = FitRoute::kNew | FitRoute::kContinue | FitRoute::kBudget},
    {.field = "exhaustive", .type = T::kFlag, .routes = unsigned(FitRoute::kBudget)},
};

std::atomic<std::uint64_t> g_checks{0};

// "`a`", "`a`, `b`", ... of the fields, and "it" or "them".
std::string named_fields(std::span<const std::string_view> fields) {
  std::string named;
  for (const std::string_view f : fields) named += (named.empty() ? "" : ", ") + option_name(f);
  return named;
}
const char* it_or_them(std::span<const std::string_view> fields) {
  return fields.size() == 1 ? "it" : "them";
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
          option_name(source.empty() ? "budget" : source));
    case FitRoute::kSweep:
      return "to a sweep: it fits each method's ladder of sizes";
    case FitRoute::kNew:
      break;
  }
  return {};
}

// The declaration of `field` that applies to a request of `route`: `method`'s, or for a
// budget or a sweep (every method) route_parameter's.
const FitParameter* applying_parameter(const MethodInfo* method, std::string_view field,
                                       FitRoute route) {
  return method ? method_parameter(*method, field) : route_parameter(field, route);
}

// The fields given that `method` does not take (a new fit): the mixture's alone, then the
// others', each refused with the methods that take it.
void refuse_fields_not_taken(std::span<const std::string_view> given, const MethodInfo& method) {
  std::vector<std::string_view> mixture_only, not_taken;
  for (const std::string_view f : given) {
    if (method_parameter(method, f)) continue;
    const std::vector<std::string_view> takers = methods_taking(f);
    (takers == std::vector<std::string_view>{kMixtureMethod} ? mixture_only : not_taken)
        .push_back(f);
  }
  if (!mixture_only.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} cannot apply to {} {}: they belong to the Gaussian mixture's fit "
                            "({} gm) only; leave {} out",
                            named_fields(mixture_only), option_name("method"), method.name,
                            option_name("method"), it_or_them(mixture_only)));
  if (not_taken.empty()) return;
  std::string takers;
  for (const std::string_view f : not_taken)
    takers += fmt::format("{}{} is taken by {}", takers.empty() ? "" : "; ", option_name(f),
                          fmt::join(methods_taking(f), ", "));
  throw Error(Error::Kind::kArgument,
              fmt::format("{} cannot apply to {} {}, which does not take {} ({}); leave {} out",
                          named_fields(not_taken), option_name("method"), method.name,
                          it_or_them(not_taken), takers, it_or_them(not_taken)));
}

// The fields given that cannot apply with `route`.
void refuse_fields_off_route(std::span<const std::string_view> given, const MethodInfo* method,
                             FitRoute route, std::string_view source) {
  std::vector<std::string_view> off_route;
  for (const std::string_view f : given) {
    const FitParameter* p = applying_parameter(method, f, route);
    if (!p || !p->takes_route(route)) off_route.push_back(f);
  }
  if (!off_route.empty())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} cannot apply {}; leave {} out", named_fields(off_route),
                            route_reason(route, source), it_or_them(off_route)));
}

// The refinement's option `field` given with an objective other than the prediction.
[[noreturn]] void refuse_refinement_without_prediction(std::string_view field) {
  throw Error(Error::Kind::kArgument,
              fmt::format("{} applies to the objective prediction only (the paper's EM, {} "
                          "likelihood, refines nothing); leave one of them out",
                          option_name(field), option_name("objective")));
}

constexpr std::string_view kRefinementFields[] = {"refine_steps", "refine_seconds",
                                                  "refine_epochs"};

// The mixture's file: compact unless asked (its own encodings; q8 is its compact).
Precision mixture_precision(const std::optional<FactorEncoding>& e) {
  if (e == FactorEncoding::kF32) return Precision::kF32;
  if (e == FactorEncoding::kF16) return Precision::kF16;
  return Precision::kCompact;
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

}  // namespace

std::span<const FitParameter> common_fit_parameters() {
  return kCommonParameters;
}

const FitParameter* method_parameter(const MethodInfo& method, std::string_view field) {
  for (const FitParameter& p : method.parameters)
    if (p.field == field) return &p;
  for (const FitParameter& p : kCommonParameters)
    if (p.field == field) return &p;
  return nullptr;
}

std::vector<const FitParameter*> fit_parameters() {
  std::vector<const FitParameter*> out;
  auto add = [&out](const FitParameter& p) {
    if (std::none_of(out.begin(), out.end(),
                     [&p](const FitParameter* q) { return q->field == p.field; }))
      out.push_back(&p);
  };
  for (const FitParameter& p : kCommonParameters) add(p);
  for (const MethodInfo& m : all_methods())
    for (const FitParameter& p : m.parameters) add(p);
  return out;
}

const FitParameter* route_parameter(std::string_view field, FitRoute route) {
  for (const FitParameter& p : kCommonParameters)
    if (p.field == field) return &p;
  const FitParameter* first = nullptr;
  for (const MethodInfo& m : all_methods())
    for (const FitParameter& p : m.parameters)
      if (p.field == field) {
        if (p.takes_route(route)) return &p;
        if (!first) first = &p;
      }
  return first;
}

const FitParameter* find_fit_parameter(std::string_view field) {
  for (const FitParameter* p : fit_parameters())
    if (p->field == field) return p;
  return nullptr;
}

std::vector<std::string_view> methods_taking(std::string_view field) {
  std::vector<std::string_view> out;
  for (const MethodInfo& m : all_methods())
    for (const FitParameter& p : m.parameters)
      if (p.field == field) out.push_back(m.name);
  return out;
}

std::string parameter_help(std::string_view field) {
  auto sentence = [](const FitParameter& p) {
    return p.default_text.empty() ? std::string(p.help)
                                  : fmt::format("{} (default {})", p.help, p.default_text);
  };
  for (const FitParameter& p : kCommonParameters)
    if (p.field == field) return sentence(p);
  std::vector<std::pair<std::string, std::vector<std::string_view>>> groups;  // help, methods
  for (const MethodInfo& m : all_methods())
    if (const FitParameter* p = method_parameter(m, field)) {
      const std::string h = sentence(*p);
      auto it =
          std::find_if(groups.begin(), groups.end(), [&h](const auto& g) { return g.first == h; });
      if (it == groups.end())
        groups.push_back({h, {m.name}});
      else
        it->second.push_back(m.name);
    }
  std::string out;
  for (const auto& [h, methods] : groups)
    out += fmt::format("{}{}: {}", out.empty() ? "" : "; ", fmt::join(methods, ", "), h);
  return out;
}

std::vector<std::string_view> given_fields(const FitOptions& o) {
  std::vector<std::string_view> out;
  for (const FitParameter* p : fit_parameters())
    if (parameter_value(o, *p)) out.push_back(p->field);
  return out;
}

void check_fit_options(const FitOptions& o, std::span<const std::string_view> given, FitRoute route,
                       std::string_view source) {
  ++g_checks;
  const bool every_method = route == FitRoute::kBudget || route == FitRoute::kSweep;
  const MethodInfo* method = every_method ? nullptr : &find_method(o.method);
  if (route == FitRoute::kNew) refuse_fields_not_taken(given, *method);
  refuse_fields_off_route(given, method, route, source);
  for (const std::string_view f : given) {
    const FitParameter* p = applying_parameter(method, f, route);
    if (const std::optional<ParameterValue> v = parameter_value(o, *p))
      check_parameter_value(*p, *v);
  }
  if (o.objective != "likelihood") return;
  for (const std::string_view f : kRefinementFields)
    if (std::find(given.begin(), given.end(), f) != given.end())
      refuse_refinement_without_prediction(f);
}

std::uint64_t fit_option_checks() {
  return g_checks.load();
}

DeviceChoice fit_device(const FitOptions& o) {
  return parse_device_choice(o.device.empty() ? "auto" : o.device).value_or(DeviceChoice::kAuto);
}

void set_refinement_options(FitConfig& config, const FitOptions& o) {
  if (config.objective != FitObjective::kPrediction)
    for (const std::string_view field : kRefinementFields)
      if (parameter_value(o, *find_fit_parameter(field)))
        refuse_refinement_without_prediction(field);
  if (o.refine_steps > 0) config.refinement_steps = o.refine_steps;
  if (o.refine_seconds > 0) config.refinement_seconds = o.refine_seconds;
  if (o.refine_epochs > 0) config.refinement_epochs = o.refine_epochs;
}

FitRequest mixture_fit_request(const FitOptions& o, const std::string& input,
                               const std::string& output) {
  FitRequest r;
  r.input = input;
  r.output = output;
  r.config = mixture_config(o.components, o.iterations, o.seed, o.threads);
  r.config.em.epsilon = o.epsilon.value_or(0.0);
  if (!o.objective.empty())  // else mixture_config's, the prediction
    r.config.objective = parse_objective(o.objective, option_name("objective"));
  set_refinement_options(r.config, o);
  r.precision = mixture_precision(o.precision);
  r.config.device = fit_device(o);
  return r;
}

std::unique_ptr<Representation> fit_representation(const FitOptions& o, const std::string& input,
                                                   std::shared_ptr<const BtfSource> source,
                                                   const Tile& tile, const FitProgress& progress) {
  if (o.method == kMixtureMethod) return fit_mixture(o, input, std::move(source), tile, progress);
  const MethodInfo& method = find_method(o.method);
  FitOptions s = o;
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
