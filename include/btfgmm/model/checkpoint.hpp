// Checkpoints of a fit: everything `btfgmm fit --resume` needs to continue a fit that was
// interrupted (SIGINT, SIGTERM, or killed outright between checkpoints) and end with the
// model an uninterrupted fit would have written, bit for bit. run_fit (fit.hpp) writes and
// reads them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm {

// Where an interrupted fit stands: the mixture after result.iterations iterations.
struct FitState {
  ProductMixture mixture;
  EmResult result;
};

struct FitCheckpoint {
  // What was fitted, and how (the command's inputs).
  std::string input;      // the BTF folder or zip, as given
  std::string output;     // the model file to write
  Tile tile;              // the tile as loaded (x, y, width, height)
  std::string made_from;  // of a made tile (Btf::made_from): how to make it again; else empty
  std::uint64_t components = 0;
  std::uint64_t seed = 0;
  std::int32_t max_iterations = 0;
  double epsilon = 0.0;
  Precision precision = Precision::kF32;
  std::uint64_t data_fingerprint = 0;  // btf_fingerprint of the tile
  std::uint32_t runs = 1;              // runs of the fit so far, the one that wrote it included
  // Where the fit stands.
  FitState state;
};

// A 64-bit FNV-1a hash of a BTF's size, direction sets and content hash (tile_content_hash,
// model/provenance.hpp): a resumed fit checks that it sees the same data. data_fingerprint
// is the same of the parts, for a model whose provenance records its tile's content hash.
std::uint64_t btf_fingerprint(const Btf& btf);
std::uint64_t data_fingerprint(const DirectionSet& lights, const DirectionSet& views, int width,
                               int height, std::uint64_t content_hash);

// Atomic (temporary file, fsync, rename). Throws Error(kIo).
void save_checkpoint(const FitCheckpoint& checkpoint, const std::filesystem::path& path);
// Throws Error(kIo / kFormat) naming the file for a missing, truncated or corrupted one.
FitCheckpoint load_checkpoint(const std::filesystem::path& path);

}  // namespace btfgmm
