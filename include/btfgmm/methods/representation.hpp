// One interface for every fitted representation of a BTF tile (docs/METHODS.md): the paper's
// Gaussian mixture and the methods its Tables 1 and 2 compare with. The model file, decode,
// eval, compare, the report, the renderer and sweep hold a Representation and never ask which
// method it is.
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
#include <utility>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {

class ComputeDevice;  // gpu/compute_device.hpp

// What every representation of a tile knows about the data it was fitted to: the direction
// sets, the tile's size and where it was cut, and the sample format.
struct ModelFrame {
  DirectionSet lights, views;
  int width = 0, height = 0;
  Tile origin;
  SampleFormat format = SampleFormat::kLdr8;

  static ModelFrame of(const Btf& tile);
  std::size_t pixels() const { return std::size_t(width) * std::size_t(height); }
  // The values of the tile's data, W*H*ni*nv*3: what Table 2's ratios divide.
  double data_values() const { return double(pixels()) * double(lights.size() * views.size()) * 3; }
};

// How a method stores its real factors in the model file (methods/factors.hpp).
enum class FactorEncoding : std::uint8_t {
  kF32 = 0,  // 32-bit floats
  kF16 = 1,  // 16-bit IEEE half floats
  kQ8 = 2,   // 8 bits per value, with a 32-bit offset and scale per row (a component)
  // Quantised with a power-of-two step per row stated in the file, predicted from the
  // neighbouring pixels or directions, zstd (format 7 on; the mixture: its compact encoding)
  kCompact = 3,
};
std::string_view to_string(FactorEncoding e);
// "compact", "f32", "f16" or "q8"; anything else throws Error(kArgument) naming `option`.
FactorEncoding parse_factor_encoding(std::string_view text, std::string_view option);

// The options of a fit of any method: the settings every method takes and each method's own
// parameters, the one options type from the front ends (the command, Python, sweep, the budget)
// to a method's fit. Each method declares which fields it takes, with their ranges, choices and
// defaults (MethodInfo::parameters, methods/registry.hpp), and check_fit_options
// (methods/fit_options.hpp) checks a request against them once. A number left at 0 and a text
// or an option left empty take the method's default.
struct FitOptions {
  std::string method = "gm";      // the method's name, as MethodInfo::name
  std::size_t components = 0;     // M for gm; eigen-images c for the PCAs; per cluster for lpca;
                                  // neural: latent values L per texel
  std::size_t clusters = 0;       // lpca: k clusters; 3d-car, 2d-car, gmrf: subspaces
  std::size_t degree = 0;         // plm-rf: degree l of the per-image polynomial
  std::size_t width = 0;          // neural: units per hidden layer of the network
  std::size_t depth = 0;          // neural: hidden layers of the network
  int iterations = 0;             // gm: EM; lpca: re-assignment rounds; plm-rf: LM steps;
                                  // neural: epochs
  int levels = 0;                 // 3d-car, 2d-car, gmrf: Gaussian-Laplacian pyramid levels
  std::optional<double> epsilon;  // gm: EM stops when L's relative gain is below it (none: 0)
  std::string objective;          // gm: "prediction" (empty) or "likelihood"
  // gm, the objective prediction: the refinement's Adam steps exactly, or its bounds in time
  // and in passes over the data in place of the default bound in steps.
  int refine_steps = 0;
  double refine_seconds = 0.0;
  int refine_epochs = 0;
  std::string device;  // gm: where EM runs: "auto" (empty), "cpu" or "gpu"
  std::uint64_t seed = 1;
  int threads = 0;  // 0: OpenMP's default; the model does not depend on it
  // How the factors are stored; none: the method's default file (default_file_encoding).
  std::optional<FactorEncoding> precision;
  // Called now and then with the fraction done (0..1) and what is under way.
  std::function<void(double fraction, std::string_view stage)> progress;
  const std::atomic<bool>* stop = nullptr;  // set: stop as soon as possible (Error(kArgument))
};

// The storage a method's fit uses: `precision`, else f16 (a fit through the registry,
// fit_and_record, has the method's default file set first).
FactorEncoding stored_encoding(const FitOptions& s);

// A fitted representation of a BTF tile.
class Representation {
 public:
  virtual ~Representation() = default;

  // The method's name as `fit --method` takes it ("gm", "pca-btf", ...).
  virtual std::string_view method() const = 0;
  virtual const ModelFrame& frame() const = 0;
  // The model's size in the method's own terms ("M = 600", "c = 8", "k = 8, c = 4") and a
  // number that orders the models of one method by size (for rate-distortion curves).
  virtual std::string size_text() const = 0;
  virtual double size_order() const = 0;
  // Stored values, counted as the paper's Table 2 counts them (docs/METHODS.md).
  virtual std::uint64_t parameter_count() const = 0;
  // The compression ratio as Table 2 counts it: by default the tile's data values against
  // parameter_count(), one for one; the mixture counts bytes (paper_compression_ratio).
  virtual double paper_ratio() const;
  // The compression ratio of the file actually written: the tile's data as 8-bit values (one
  // byte a value, as Table 2 counts the data) against `file_bytes`.
  double file_ratio(std::uint64_t file_bytes) const;

  // The RGB of every query (3 floats a query), in the data's scale: any pixel (the tile
  // repeats), any light and view on the hemisphere. Throws Error(kArgument) for a direction
  // off the hemisphere.
  virtual void predict(std::span<const Query> queries, std::span<float> rgb) const = 0;
  // Images of width x height pixels (the tile repeated) for every pair of the given sets.
  // `tolerance` (levels) lets a method skip work that moves no value by more than it; 0 is
  // exact. Throws Error(kArgument) for a direction off the hemisphere or a bad size.
  virtual Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
                     double tolerance) const = 0;

  // The method's part of the model file (model/model_file.hpp: after the method tag), and
  // the header flags it needs.
  virtual std::vector<std::uint8_t> payload() const = 0;
  // How the payload stores its real values (the precision `fit --precision` chose).
  virtual FactorEncoding encoding() const = 0;
  virtual std::uint32_t file_flags() const { return 0; }
  // Named facts for `info` and the report ("eigen-images", "16"), in display order.
  virtual std::vector<std::pair<std::string, std::string>> details() const { return {}; }

  // Whether the method synthesises new texture with the data's statistics (the probabilistic
  // texture models, docs/METHODS.md) instead of reproducing the data's pixels: `compare` then
  // measures statistics and marks the pixel-wise figures as not meaningful.
  virtual bool synthesises() const { return false; }
  // The seed of that synthesis, for predict and decode. A method that does not synthesise
  // throws Error(kArgument) naming `option`.
  virtual void set_synthesis_seed(std::uint64_t seed, std::string_view option);

  // Where predict and decode compute from now on: on `device` (a compute device,
  // gpu/compute_device.hpp), or on the CPU for null. Returns false, and goes on computing on the
  // CPU, where the method has no kernels for a device (by default).
  virtual bool compute_on(std::shared_ptr<ComputeDevice> device);

  // The data it was fitted to and the fit's log, written to its model file and read back
  // (none recorded for older files); fit_and_record (methods/registry.hpp) records it.
  const Provenance& provenance() const { return provenance_; }
  void set_provenance(Provenance p) { provenance_ = std::move(p); }

 private:
  Provenance provenance_;
};

}  // namespace btfgmm
