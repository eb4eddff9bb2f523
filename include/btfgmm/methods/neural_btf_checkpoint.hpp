// Checkpoints of the neural BTF's fit (methods/neural_btf.hpp): where a fit stands between two
// Adam steps, saved so that `btfgmm fit --resume` goes on and writes the model an
// uninterrupted fit writes, bit for bit (the parameters; the provenance's times aside). The
// file follows the mixture's checkpoint (model/checkpoint.hpp): magic, version, the fit job,
// the state, CRC-32; docs/FORMAT.md, "Checkpoints".
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/neural_btf.hpp"

namespace btfgmm {

// The fit's state before step `steps_done` of epoch `epoch` (the training samples shuffled
// from the seed and the epoch); `validation_due`: the held-out check that follows step
// steps_done - 1 is still to come (a fit stopped after that step).
struct NeuralFitState {
  std::int32_t epoch = 0;
  std::uint64_t steps_done = 0;
  bool validation_due = false;
  // Adam's parameters (the network's, then the latents), moments and step count.
  std::vector<float> theta, first_moment, second_moment;
  std::int32_t adam_steps = 0;
  // The lowest held-out error met (levels) and its parameters.
  std::vector<float> best_theta;
  double best_rmse = 0.0;
  // The stopping rule: the lowest error met (the network's units), the error a gain is
  // measured from, the rates' scale, validations since a gain, halvings so far.
  double rule_best = 0.0, rule_reference = 0.0, rate_scale = 1.0;
  std::int32_t since_gain = 0, plateaus = 0;
};

// A fit's checkpoints: `save` called with the state after every `every_epochs` epochs (but the
// last; 0: none) and when the fit is stopped; a fit from `resume` goes on from it.
struct NeuralCheckpointing {
  int every_epochs = 1;
  std::function<void(const NeuralFitState& state)> save;
  const NeuralFitState* resume = nullptr;
};

// fit_neural_btf with checkpoints. Throws Error(kFormat) for a state whose sizes are not the
// shape's on this tile.
std::unique_ptr<Representation> fit_neural_btf(const Btf& tile, const FitOptions& s,
                                               const NeuralCheckpointing& checkpointing);

// The checkpoint file: the fit job (what `fit` was given) and where it stands.
struct NeuralCheckpoint {
  std::string input;                   // the BTF folder or zip, as given
  std::string output;                  // the model file to write
  Tile tile;                           // the tile as loaded
  FitOptions options;                  // method "neural": L, width, depth, epochs, seed, precision
  std::uint64_t data_fingerprint = 0;  // btf_fingerprint (model/checkpoint.hpp) of the tile
  double seconds = 0.0;                // the fit's time so far
  std::uint32_t runs = 1;              // runs so far, the one that wrote it included
  NeuralFitState state;
  std::string made_from;  // of a made tile (Btf::made_from): how to make it again; else empty
};

// The first bytes of a neural fit's checkpoint (another file: false).
bool is_neural_checkpoint(std::span<const std::uint8_t> bytes);
bool is_neural_checkpoint_file(const std::filesystem::path& path);
// Atomic (temporary file, fsync, rename). Throws Error(kIo).
void save_neural_checkpoint(const NeuralCheckpoint& c, const std::filesystem::path& path);
// Throws Error(kFormat) naming `name` for a truncated, corrupted or inconsistent file.
NeuralCheckpoint read_neural_checkpoint(std::span<const std::uint8_t> bytes,
                                        const std::string& name);
// Throws Error(kIo / kFormat) naming the file.
NeuralCheckpoint load_neural_checkpoint(const std::filesystem::path& path);

// fit_representation's neural fit (methods/fit_options.hpp) with its state saved to
// `checkpoint` every `every_epochs` epochs (0: none) and when stopped; with `resume`, the fit that
// checkpoint holds goes on (its input, tile and options; `o` gives the threads), its data
// checked to be the same. The provenance counts the time and runs before.
struct NeuralFitJob {
  FitOptions options;  // method "neural" (a resume: the checkpoint's, `threads` from here)
  std::string input, output;
  Tile tile;
  std::string checkpoint;  // empty: none saved
  int every_epochs = 1;
  const NeuralCheckpoint* resume = nullptr;
};
std::unique_ptr<Representation> fit_neural_job(const NeuralFitJob& job,
                                               std::shared_ptr<const BtfSource> source,
                                               const FitProgress& progress = {});

}  // namespace btfgmm
