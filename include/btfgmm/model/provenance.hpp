// A model's provenance (docs/FORMAT.md, "Provenance"): what identifies the data it was fitted
// to, beside what its frame holds (the direction sets, the tile, the sample format), and the
// fit's log (settings, time, and for the mixture every EM iteration). Model files of format 3
// carry one; older files, and models made in memory without one, have none.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "btfgmm/core/btf.hpp"

namespace btfgmm {

// Where a tile was read from: the data set as it was named, and the size of its images
// (0 x 0 and an empty name: not known, e.g. a tile made in memory).
struct DataSource {
  std::string name;  // the folder or .zip as given to fit
  int image_width = 0, image_height = 0;
};

// The data a model was fitted to, with the model's frame.
struct DataFingerprint {
  DataSource source;
  std::uint64_t content_hash = 0;  // tile_content_hash of the tile fitted
};

// One EM iteration as the fit logged it.
struct IterationRecord {
  double log_likelihood = 0.0;   // L of Eq. (3) for the parameters the iteration started from
  double seconds = 0.0;          // EM time at its end since the fit began (every run of it)
  std::uint32_t components = 0;  // alive after its M-step
};

struct FitLog {
  // Every setting of the fit as (name, value), e.g. ("components", "600"), in order.
  std::vector<std::pair<std::string, std::string>> settings;
  // The fit's time: this run's, plus, for a fit that was resumed or continued, the EM time
  // of the runs before it up to the state it went on from.
  double seconds = 0.0;
  std::uint32_t runs = 1;                   // 1; one more for each resume or continuation
  std::vector<IterationRecord> iterations;  // EM's (the mixture); empty for other methods
};

// The value of the setting "reproducible" of a fit bounded in time (a refinement's
// `refine_seconds`): its model depends on the machine and its load. A fit without the
// setting is a function of its data, settings and seed.
constexpr std::string_view kBoundInTime =
    "no: the refinement was bounded in time, so the model depends on the machine and its load";

// The setting a fit stopped by the user before its end records (a method whose fit keeps the
// best model met, as the neural BTF's does): where it stopped. Such a model is not what the
// settings give uninterrupted.
constexpr std::string_view kStoppedSetting = "stopped by the user";

// The setting naming the made tile a model was fitted to (a seamless tile cut from the data,
// btfgmm/measure/seamless_tile.hpp): SeamlessTile::describe(). A model of a crop has none.
constexpr std::string_view kTileSetting = "tile";

// The setting naming the GPU a method's own fit ran on (the neural BTF's, docs/GPU.md): such a
// model is the CPU's to float rounding, not bit for bit. A fit on the CPU does not record it.
constexpr std::string_view kDeviceSetting = "device";

struct Provenance {
  bool recorded = false;  // false: an older file, or a model made without one
  DataFingerprint data;
  FitLog fit;
};

// FNV-1a (64-bit) of the tile's values as stored in memory: every float's 4 bytes,
// little-endian, in Btf order (light-major images, rows, RGB). Equal tiles of any two reads
// of the same images hash equal; a changed value changes it.
std::uint64_t tile_content_hash(const Btf& tile);
// The same hash in pieces: from kContentHashBasis, each run of values in that order.
constexpr std::uint64_t kContentHashBasis = 0xcbf29ce484222325ull;  // FNV-1a offset basis
std::uint64_t content_hash_add(std::uint64_t hash, std::span<const float> values);
// The fingerprint of `tile`, read from `source`.
DataFingerprint fingerprint_of(const Btf& tile, DataSource source);
// 16 hexadecimal digits.
std::string hash_text(std::uint64_t hash);
// "'corduroy32/' (its 25x25 tile of 32x32 images, content hash 0123456789abcdef)" for
// messages; "no provenance recorded" without one.
std::string describe_source(const Provenance& p, const Tile& tile);

}  // namespace btfgmm
