// Every method btfgmm fits, by name (docs/METHODS.md): how to fit it, read it from a model
// file, and which sizes span its range on a tile. The one place that lists the methods.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/methods/parameters.hpp"
#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

// `fit --budget`'s quick search of a method's size (measure/budget.hpp), for a method whose
// fits take minutes: the size at the budget predicted from the files of short fits (probes),
// and only that size fitted in full.
struct QuickSizeSearch {
  // A setting of the same size as `s` whose fit takes a small part of `s`'s time and whose
  // file's bytes that grow with the size, times `bytes_ratio`, are about those of `s`'s file.
  std::function<FitOptions(const FitOptions& s)> probe;
  double bytes_ratio = 1.0;
  // A model as it would be of size 0: its file holds the bytes that do not grow with the size
  // (a header, the provenance, the mixture's mean BRDF).
  std::function<std::unique_ptr<Representation>(const Representation& model)> without_size;
  // The largest size the choice `s` takes on a tile of `frame`, where it takes fewer than its
  // probe (the mixture's prediction objective: one component per 64 training samples).
  std::function<std::size_t(const ModelFrame& frame, const FitOptions& s)> most_size;
  // The setting the chosen size is fitted with: `s` with the search's own defaults where the
  // request did not give the field (`given`).
  std::function<FitOptions(FitOptions s, std::span<const std::string_view> given)> choice;
  // What the two do, as the search's plan states it.
  std::string summary;
};

struct MethodInfo {
  std::string_view name;      // as `fit --method` takes it
  std::string_view title;     // "PCA BTF: one PCA of all images"
  std::string_view citation;  // "Koudelka, Magda, Belhumeur, Kriegman 2003"
  // The options that set its size, named as messages name them (core/text.hpp, option_name):
  // "`components` c (eigen-images, 61)".
  std::string_view sizes;
  // The method's own parameters (methods/parameters.hpp); with the ones every method takes
  // (common_fit_parameters, methods/fit_options.hpp), every field a fit of it may be given.
  std::span<const FitParameter> parameters;
  // Fits the method to a tile. Throws Error(kArgument) naming the option and its allowed
  // range for a setting the tile cannot take.
  std::function<std::unique_ptr<Representation>(const Btf& tile, const FitOptions& s)> fit;
  // Reads the method's payload (model/model_file.hpp); Error(kFormat) naming `name`.
  std::function<std::unique_ptr<Representation>(std::span<const std::uint8_t> payload,
                                                std::uint32_t flags, const std::string& name)>
      read;
  // Settings that span compression ratios from about 1:5 to 1:500 on a tile of this frame
  // (as Table 2 counts them), smallest model first; `sweep` fits each.
  std::function<std::vector<FitOptions>(const ModelFrame& frame)> ladder;
  // Its models synthesise new texture (Representation::synthesises): `fit --budget` leaves it
  // out without fitting it, since no pixel-wise PSNR measures it.
  bool synthesises = false;
  // How `fit --budget` finds its size at a budget without fitting each size tried in full
  // (measure/budget.hpp); none: each size is fitted as `sweep` fits it.
  QuickSizeSearch quick_search = {};
  // A copy of `model` stored with every quantisation step `factor` (> 1) times as coarse: a
  // smaller file, each value within half the coarser step; none where the method's storage
  // states no steps. `fit --budget` takes it to bring a file a few percent over the budget
  // within it.
  std::function<std::unique_ptr<Representation>(const Representation& model, double factor)>
      coarsened = {};
};

// The encoding of the file `fit` writes for `method` when no precision is asked: the default
// its declaration of `precision` states (compact, the mixture's its own compact format; f16
// for the range maps of 3D CAR, 2D CAR and GMRF; docs/METHODS.md, "Storage"). `fit`, `sweep` and
// `fit --budget` store every model so, so that the sizes they compare are the sizes a user gets
// (the mixture: its compact format; the others: their declared default).
FactorEncoding default_file_encoding(const MethodInfo& method);

// Every method, the Gaussian mixture ("gm") first.
std::span<const MethodInfo> all_methods();
// Throws Error(kArgument) for an unknown name, listing the methods (and the nearest name).
const MethodInfo& find_method(std::string_view name);

// Fits `method` to `tile` and records the model's provenance: `data`, the tile's fingerprint
// (fingerprint_of, computed once for many fits of one tile), the settings as asked (and the
// size they gave), the fit's time, and for the mixture its EM log. Throws as the method's fit.
std::unique_ptr<Representation> fit_and_record(const MethodInfo& method, const Btf& tile,
                                               const FitOptions& settings,
                                               const DataFingerprint& data);

// Any method's model file: read (Error(kFormat) naming the file and, where it holds something
// else, what: an archive, an image, ...), written atomically. Every command that reads a model
// reads it by load_representation, which refuses a folder (Error(kArgument); a folder of
// images: with the command that fits it).
std::unique_ptr<Representation> read_representation(std::span<const std::uint8_t> bytes,
                                                    const std::string& name);
std::unique_ptr<Representation> load_representation(const std::filesystem::path& path);
std::vector<std::uint8_t> representation_file_bytes(const Representation& r);
// Returns the file's size in bytes.
std::uint64_t save_representation(const Representation& r, const std::filesystem::path& path);

}  // namespace btfgmm
