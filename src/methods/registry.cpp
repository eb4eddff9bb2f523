// The methods by name, and the model file of any method.
#include "btfgmm/methods/registry.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/file_kind.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/methods/lpca.hpp"
#include "btfgmm/methods/neural_btf.hpp"
#include "btfgmm/methods/pca_btf.hpp"
#include "btfgmm/methods/pca_rf.hpp"
#include "btfgmm/methods/plm_rf.hpp"
#include "btfgmm/methods/ptm_rf.hpp"
#include "btfgmm/methods/texture_models.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/refine.hpp"

namespace btfgmm {
namespace {

std::unique_ptr<Representation> read_gaussian_mixture(std::span<const std::uint8_t> payload,
                                                      std::uint32_t flags,
                                                      const std::string& name) {
  return std::make_unique<GaussianMixture>(read_mixture_payload(payload, flags, name));
}

// M from 10 to 600 (the default fit's), at most twice apart above 30: the mixture's own
// ladder (its ratio, as the paper counts it, is set mostly by the mean BRDF on small tiles).
std::vector<FitOptions> mixture_ladder(const ModelFrame&) {
  std::vector<FitOptions> out;
  for (std::size_t m : {10, 30, 100, 200, 300, 450, 600}) {
    FitOptions s;
    s.components = m;
    out.push_back(s);
  }
  return out;
}

// PTM RF has one size.
std::vector<FitOptions> ptm_rf_ladder(const ModelFrame&) {
  return {FitOptions{}};
}

// PLM RF's size hardly moves with the polynomial's degree (the lobes dominate): l = 1, 2, 4.
std::vector<FitOptions> plm_rf_ladder(const ModelFrame&) {
  std::vector<FitOptions> out;
  for (std::size_t l : {1, 2, 4}) {
    FitOptions s;
    s.degree = l;
    out.push_back(s);
  }
  return out;
}

// ---- Each method's parameters (methods/parameters.hpp): the fields it takes -------------

using T = ParameterType;
constexpr unsigned kMixtureRoutes = FitRoute::kNew | FitRoute::kResume | FitRoute::kContinue;
constexpr unsigned kAnyRoute = kMixtureRoutes | FitRoute::kBudget | FitRoute::kSweep;
constexpr unsigned kNewFit = unsigned(FitRoute::kNew);
constexpr double kMaxSize = 100000;

// The precision of the factor methods' files (its default their file's: default_file_encoding).
constexpr FitParameter kFactorPrecision = {
    .field = "precision",
    .type = T::kWord,
    .member = &FitOptions::precision,
    .choices = "compact f32 f16 q8",
    .default_text = "compact",
    .routes = FitRoute::kNew | FitRoute::kSweep,
    .help =
        "compact (quantised with a step per component, predicted from neighbouring pixels "
        "or directions, zstd), f32, f16 or q8 (8 bits with an offset and scale per "
        "component)"};

// A size of the model (mixture components, eigen-images, clusters), given to a new fit.
constexpr FitParameter model_size(std::string_view field, std::size_t FitOptions::*member,
                                  std::string_view default_text, std::string_view help) {
  return {.field = field,
          .type = T::kCount,
          .member = member,
          .min = 1,
          .max = kMaxSize,
          .default_text = default_text,
          .routes = kNewFit,
          .help = help};
}

// The most iterations of a method that iterates (EM, rounds, LM steps), on any route.
constexpr FitParameter most_iterations(std::string_view default_text, std::string_view help) {
  return {.field = "iterations",
          .type = T::kInteger,
          .member = &FitOptions::iterations,
          .min = 1,
          .max = kMaxSize,
          .default_text = default_text,
          .routes = kAnyRoute,
          .help = help};
}

// Where a method's fit computes (a compute device, docs/GPU.md), on any route.
constexpr FitParameter device_parameter(std::string_view help) {
  return {.field = "device",
          .type = T::kWord,
          .member = &FitOptions::device,
          .choices = "auto cpu gpu",
          .default_text = "auto",
          .routes = kAnyRoute,
          .help = help};
}

constexpr FitParameter kMixtureParameters[] = {
    model_size("components", &FitOptions::components, "600", "mixture components M"),
    most_iterations("40", "the most EM iterations (resumed or continued: the total to go on to)"),
    {.field = "epsilon",
     .type = T::kReal,
     .member = &FitOptions::epsilon,
     .min = 0,
     .max = 1,
     .default_text = "0",
     .routes = kMixtureRoutes,
     .help = "EM stops when the relative gain of L is below this"},
    {.field = "objective",
     .type = T::kWord,
     .member = &FitOptions::objective,
     .choices = "prediction likelihood",
     .default_text = "prediction",
     .routes = FitRoute::kNew | FitRoute::kResume,
     .help = "prediction (EM, then the mixture refined for the prediction's error, Eq. 8-11: "
             "the colour means by least squares, gradient steps on every parameter, the colour "
             "means again) or likelihood (the paper's EM alone, exactly)"},
    {.field = "refine_steps",
     .type = T::kInteger,
     .member = &FitOptions::refine_steps,
     .min = 1,
     .max = kMaxRefineSteps,
     .routes = kMixtureRoutes,
     .help = "with the objective prediction, exactly this many Adam steps of the refinement "
             "(default: until the error on the held-out samples stops falling, at most 2400, "
             "docs/ALGORITHM.md)"},
    {.field = "refine_seconds",
     .type = T::kReal,
     .member = &FitOptions::refine_seconds,
     .min = 1,
     .max = kMaxRefineSeconds,
     .routes = kAnyRoute,
     .help =
         "with the objective prediction, the most seconds the refinement takes, in place of the "
         "default bound in steps (the lowest held-out error met is kept); the model then "
         "depends on the machine and its load, as its provenance says"},
    {.field = "refine_epochs",
     .type = T::kInteger,
     .member = &FitOptions::refine_epochs,
     .min = 1,
     .max = kMaxRefineEpochs,
     .routes = kAnyRoute,
     .help =
         "with the objective prediction, the most passes over the tile's samples the refinement "
         "takes, in place of the default bound of at most 2400 steps"},
    device_parameter(
        "where EM and the refinement's steps run, and the predictions sweep and the "
        "budget's search measure: auto (a GPU where one exists, else the CPU), cpu, or gpu "
        "(a GPU, else a software Vulkan such as lavapipe; docs/GPU.md)"),
    {.field = "precision",
     .type = T::kWord,
     .member = &FitOptions::precision,
     .choices = "compact f32 f16 q8",
     .default_text = "compact",
     .routes = FitRoute::kNew | FitRoute::kSweep,
     .help = "compact (each parameter quantised with a stated step, zstd; docs/FORMAT.md; q8 "
             "is the same), f32 (exact, for continue to match one longer fit) or f16"},
    // The mixture's fit job: checkpoints, resuming, continuing, its log (the front end's).
    {.field = "checkpoint", .type = T::kText, .routes = kMixtureRoutes},
    {.field = "checkpoint_every",
     .type = T::kInteger,
     .min = 1,
     .max = kMaxSize,
     .routes = kMixtureRoutes},
    {.field = "resume", .type = T::kText, .routes = unsigned(FitRoute::kResume)},
    {.field = "continue", .type = T::kText, .routes = unsigned(FitRoute::kContinue)},
    {.field = "log", .type = T::kText, .routes = kMixtureRoutes},
};

constexpr FitParameter kPcaBtfParameters[] = {
    model_size("components", &FitOptions::components, "61", "eigen-images c"),
    kFactorPrecision,
};

constexpr FitParameter kPcaRfParameters[] = {
    model_size("components", &FitOptions::components, "6", "eigen-images c per view"),
    kFactorPrecision,
};

constexpr FitParameter kLpcaParameters[] = {
    model_size("components", &FitOptions::components, "4", "components c per cluster"),
    model_size("clusters", &FitOptions::clusters, "8", "clusters k"),
    most_iterations("20", "the most re-assignment rounds"),
    kFactorPrecision,
};

constexpr FitParameter kPtmRfParameters[] = {kFactorPrecision};

constexpr FitParameter kPlmRfParameters[] = {
    {.field = "degree",
     .type = T::kCount,
     .member = &FitOptions::degree,
     .min = 0,
     .max = 64,
     .default_text = "4",
     .routes = kNewFit,
     .help = "the degree l of the per-image polynomial"},
    most_iterations("30", "the most Levenberg-Marquardt steps"),
    kFactorPrecision,
};

constexpr FitParameter kTextureModelParameters[] = {
    model_size("clusters", &FitOptions::clusters, "15", "BTF subspaces c"),
    {.field = "levels",
     .type = T::kInteger,
     .member = &FitOptions::levels,
     .min = 1,
     .max = 16,
     .default_text = "3",
     .routes = kNewFit,
     .help = "levels K of each subspace image's Gaussian-Laplacian pyramid, a model each (3, "
             "or as many as the tile holds with the coarsest level at least 8 x 8 pixels)"},
    {.field = "precision",
     .type = T::kWord,
     .member = &FitOptions::precision,
     .choices = "f16 f32 compact q8",
     .default_text = "f16",
     .routes = FitRoute::kNew | FitRoute::kSweep,
     .help = "the range map's storage (its few model parameters are always f32)"},
};

// The row of one of the probabilistic texture models (Haindl, Filip 2007), which share their
// sizes, parameters and ladder, and synthesise new texture.
MethodInfo texture_model_row(std::string_view name, std::string_view title,
                             decltype(MethodInfo::fit) fit, decltype(MethodInfo::read) read) {
  return {.name = name,
          .title = title,
          .citation = "Haindl, Filip 2007",
          .sizes = "`clusters` c (subspaces, 15), `levels` K (pyramid, 3)",
          .parameters = kTextureModelParameters,
          .fit = std::move(fit),
          .read = std::move(read),
          .ladder = texture_model_ladder,
          .synthesises = true};
}

constexpr FitParameter kNeuralParameters[] = {
    model_size("components", &FitOptions::components, "8", "latent values L per texel"),
    {.field = "width",
     .type = T::kCount,
     .member = &FitOptions::width,
     .min = 1,
     .max = 512,
     .default_text = "64",
     .routes = kNewFit,
     .help = "units per hidden layer of the network"},
    {.field = "depth",
     .type = T::kCount,
     .member = &FitOptions::depth,
     .min = 1,
     .max = 16,
     .default_text = "2",
     .routes = kNewFit,
     .help = "hidden layers of the network"},
    most_iterations("30",
                    "the most epochs (passes over the training samples; by default fewer "
                    "where 30 take more than 18,000 Adam steps, but at least 6 where those "
                    "take at most 40,000); the held-out error ends them earlier"),
    {.field = "precision",
     .type = T::kWord,
     .member = &FitOptions::precision,
     .choices = "compact f32 f16 q8",
     .default_text = "compact",
     .routes = FitRoute::kNew | FitRoute::kSweep,
     .help = "the latents' storage: compact (quantised with a step per latent dimension, "
             "predicted from neighbouring texels, zstd), f32, f16 or q8; the network is always "
             "16-bit floats"},
    device_parameter(
        "where the network's forward and backward passes run (the Adam steps and the "
        "validation): auto (a GPU where one exists, else the CPU), cpu, or gpu (a GPU, "
        "else a software Vulkan such as lavapipe; docs/GPU.md, \"The neural fit\")"),
    // The fit job's checkpoints and resuming (methods/neural_btf_checkpoint.hpp).
    {.field = "checkpoint", .type = T::kText, .routes = FitRoute::kNew | FitRoute::kResume},
    {.field = "checkpoint_every",
     .type = T::kInteger,
     .min = 1,
     .max = kMaxSize,
     .routes = FitRoute::kNew | FitRoute::kResume},
    {.field = "resume", .type = T::kText, .routes = unsigned(FitRoute::kResume)},
};

// The neural BTF's row (Rainer, Jakob, Ghosh & Weyrich 2019).
MethodInfo neural_btf_row() {
  return {
      .name = "neural",
      .title = "Neural BTF: a latent vector per texel, one network of latent, light and view",
      .citation = "Rainer, Jakob, Ghosh, Weyrich 2019",
      .sizes = "`components` L (latent values per texel, 8), `width` (64), `depth` (2)",
      .parameters = kNeuralParameters,
      .fit = fit_neural_btf,
      .read = read_neural_btf,
      .ladder = neural_btf_ladder,
      .quick_search = {.probe = neural_byte_probe,
                       .bytes_ratio = kNeuralProbeBytesRatio,
                       .without_size = neural_without_latents,
                       .most_size = {},
                       .choice = [](FitOptions s, std::span<const std::string_view>) { return s; },
                       .summary = fmt::format("its L predicted from the files of {} epoch "
                                              "fits, the choice fitted as by default",
                                              kNeuralProbeEpochs)}};
}

// One row a method (docs/METHODS.md); `sizes` names the options that set its size.
const std::vector<MethodInfo>& table() {
  static const std::vector<MethodInfo> methods = {
      {.name = "gm",
       .title = "Gaussian mixture of product components over (x, y, light, view, RGB)",
       .citation = "the paper btfgmm started from, Eq. (1)-(11)",
       .sizes = "`components` M (mixture components), `iterations` (EM)",
       .parameters = kMixtureParameters,
       .fit = fit_gaussian_mixture,
       .read = read_gaussian_mixture,
       .ladder = mixture_ladder,
       .quick_search = {.probe = mixture_byte_probe,
                        .bytes_ratio = kProbeBytesRatio,
                        .without_size = mixture_without_components,
                        .most_size = mixture_most_components,
                        .choice = mixture_budget_choice,
                        .summary = fmt::format(
                            "its size predicted from the files of {} EM iterations, the choice "
                            "fitted with at most {} (then refined for the prediction)",
                            kProbeIterations, kBudgetIterations)},
       .coarsened = coarsened_mixture},
      {.name = "pca-btf",
       .title = "PCA BTF: one PCA of all images",
       .citation = "Koudelka, Magda, Belhumeur, Kriegman 2003",
       .sizes = "`components` c (eigen-images, 61)",
       .parameters = kPcaBtfParameters,
       .fit = fit_pca_btf,
       .read = read_pca_btf,
       .ladder = pca_btf_ladder},
      {.name = "pca-rf",
       .title = "PCA RF: a PCA of each view's images",
       .citation = "Sattler, Sarlette, Klein 2003",
       .sizes = "`components` c (eigen-images per view, 6)",
       .parameters = kPcaRfParameters,
       .fit = fit_pca_rf,
       .read = read_pca_rf,
       .ladder = pca_rf_ladder},
      {.name = "lpca",
       .title = "LPCA: a local PCA of the texels' apparent BRDFs (k clusters, a PCA each)",
       .citation = "Mueller, Meseth, Klein 2003; Kambhatla, Leen 1997",
       .sizes = "`clusters` k (8), `components` c (per cluster, 4), `iterations` (rounds, 20)",
       .parameters = kLpcaParameters,
       .fit = fit_lpca,
       .read = read_lpca,
       .ladder = lpca_ladder},
      {.name = "ptm-rf",
       .title = "PTM RF: a polynomial texture map (biquadratic in the light) per view",
       .citation = "Malzbender, Gelb, Wolters 2001",
       .sizes = "none (6 coefficients per texel, view and channel)",
       .parameters = kPtmRfParameters,
       .fit = fit_ptm_rf,
       .read = read_ptm_rf,
       .ladder = ptm_rf_ladder},
      {.name = "plm-rf",
       .title = "PLM RF: a Lafortune lobe per texel and view, a polynomial per image",
       .citation = "Filip, Haindl 2004",
       .sizes = "`degree` l (4) of the per-image polynomial, `iterations` (30)",
       .parameters = kPlmRfParameters,
       .fit = fit_plm_rf,
       .read = read_plm_rf,
       .ladder = plm_rf_ladder},
      neural_btf_row(),
      texture_model_row(
          "3d-car", "3D CAR: BTF subspaces, a causal autoregressive model of RGB each, a range map",
          fit_car3d, read_car3d),
      texture_model_row(
          "2d-car",
          "2D CAR: BTF subspaces, a causal autoregressive model per colour band, a range map",
          fit_car2d, read_car2d),
      texture_model_row(
          "gmrf",
          "GMRF: BTF subspaces, a Gaussian Markov random field per colour band, a range map",
          fit_gmrf, read_gmrf),
  };
  return methods;
}

// The settings a fit was asked for, as its provenance records them: those set (a size left
// at 0 took the method's default, which its size text gives), the seed, the encoding and
// the threads.
std::vector<std::pair<std::string, std::string>> settings_record(const MethodInfo& method,
                                                                 const FitOptions& s) {
  std::vector<std::pair<std::string, std::string>> out = {{"method", std::string(method.name)}};
  auto add = [&](const char* name, std::size_t v) {
    if (v) out.emplace_back(name, std::to_string(v));
  };
  add("components", s.components);
  add("clusters", s.clusters);
  add("degree", s.degree);
  add("width", s.width);
  add("depth", s.depth);
  add("iterations", std::size_t(std::max(s.iterations, 0)));
  add("levels", std::size_t(std::max(s.levels, 0)));
  // The mixture's refinement's bounds, named as its own fit records them (model/fit.cpp).
  if (s.refine_seconds > 0) {
    out.emplace_back("refine seconds", fmt::format("{:g}", s.refine_seconds));
    out.emplace_back("reproducible", std::string(kBoundInTime));
  }
  add("refine epochs", std::size_t(std::max(s.refine_epochs, 0)));
  out.emplace_back("seed", std::to_string(s.seed));
  out.emplace_back("precision", std::string(to_string(stored_encoding(s))));
  // Not the threads: the model is the same with any number (docs/FORMAT.md, "Provenance").
  return out;
}

}  // namespace

std::unique_ptr<Representation> fit_and_record(const MethodInfo& method, const Btf& tile,
                                               const FitOptions& settings,
                                               const DataFingerprint& data) {
  const auto t0 = Clock::now();
  FitOptions s = settings;
  if (!s.precision) s.precision = default_file_encoding(method);
  std::unique_ptr<Representation> r = method.fit(tile, s);
  Provenance p = r->provenance();  // the mixture's holds its EM log
  p.recorded = true;
  p.data = data;
  p.fit.settings = settings_record(method, s);
  p.fit.settings.emplace_back("size", r->size_text());
  if (!tile.made_from().empty()) p.fit.settings.emplace_back(kTileSetting, tile.made_from());
  for (const auto& [name, value] : r->provenance().fit.settings)
    if (name == kStoppedSetting || (name == kDeviceSetting && value != "cpu"))
      p.fit.settings.emplace_back(name, value);
  p.fit.seconds = seconds_since(t0);
  p.fit.runs = 1;
  r->set_provenance(std::move(p));
  return r;
}

FactorEncoding default_file_encoding(const MethodInfo& method) {
  const FitParameter* precision = method_parameter(method, "precision");
  return parse_factor_encoding(precision->default_text, option_name("precision"));
}

std::span<const MethodInfo> all_methods() {
  return table();
}

const MethodInfo& find_method(std::string_view name) {
  for (const MethodInfo& m : table())
    if (m.name == name) return m;
  std::vector<std::string_view> names;
  for (const MethodInfo& m : table()) names.push_back(m.name);
  throw Error(Error::Kind::kArgument,
              fmt::format("unknown method '{}'{}; the methods are: {}", name,
                          did_you_mean(name, names), fmt::join(names, ", ")));
}

std::unique_ptr<Representation> read_representation(std::span<const std::uint8_t> bytes,
                                                    const std::string& name) {
  const ModelFileContents c = open_model_file(bytes, name);
  for (const MethodInfo& m : table())
    if (m.name == c.method) {
      std::unique_ptr<Representation> r = m.read(c.payload, c.flags, name);
      r->set_provenance(c.provenance);
      return r;
    }
  throw Error(Error::Kind::kFormat,
              fmt::format("model file '{}' holds a '{}' model, a method this btfgmm does not "
                          "know; use a newer btfgmm",
                          name, c.method));
}

namespace {

// Whether a folder holds images (in it or in its subfolders, as the UTIA layout has them), in
// any format: a BTF, or one in a format to convert.
bool holds_images(const std::filesystem::path& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    if (it.depth() > 1) it.disable_recursion_pending();
    const std::string name = it->path().filename().string();
    if (image_format_from_name(name) || unread_image_format_from_name(name)) return true;
  }
  return false;
}

// Error(kArgument) when `path` is a folder, where a model file was expected: a folder of BTF
// images is fitted first.
void check_not_folder(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_directory(path, ec)) return;
  if (holds_images(path))
    throw Error(Error::Kind::kArgument,
                fmt::format("'{}' is a folder of images, not a model; fit a model to it first, "
                            "then give the model file here",
                            path.string()));
  throw Error(Error::Kind::kArgument,
              fmt::format("'{}' is a folder, not a model file; give a .btfgmm model file (what "
                          "a fit writes)",
                          path.string()));
}

}  // namespace

std::unique_ptr<Representation> load_representation(const std::filesystem::path& path) {
  check_not_folder(path);
  // A file of another kind (an archive of images may be gigabytes) is named from its first
  // bytes, before it is read whole: the reader refuses it as such.
  const std::vector<std::uint8_t> start = read_file_start(path, 512);
  if (identify_file(start)) read_representation(start, path.string());
  return read_representation(read_whole_file(path, "model file"), path.string());
}

std::vector<std::uint8_t> representation_file_bytes(const Representation& r) {
  return model_file_bytes(r.method(), r.file_flags(), r.provenance(), r.payload());
}

std::uint64_t save_representation(const Representation& r, const std::filesystem::path& path) {
  const auto bytes = representation_file_bytes(r);
  write_file_atomically(path, bytes, "model file");
  return bytes.size();
}

}  // namespace btfgmm
