// The model file (docs/FORMAT.md): versioned, checksummed, written atomically. Version 3
// records the model's provenance (model/provenance.hpp) after the method tag; version 2 tags
// the payload with the method that wrote it (methods/registry.hpp reads any method); version 1
// files hold a Gaussian mixture and are read as such. Versions 1 and 2 have no provenance.
// Version 4 adds the mixture's compact encoding (flags 2); version 5 predicts its mean BRDF
// (flags 6); version 6 adds the texture models' image moments (flags 8); version 7 predicts
// them (flags 24); version 8 adds their relief structure (flags 56).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/model/model.hpp"
#include "btfgmm/model/provenance.hpp"

namespace btfgmm {

constexpr std::uint32_t kModelFormatVersion = 8;
// The mixture's flags: its Precision, and with the compact encoding (version 5 on) this bit,
// the mean BRDF's codes predicted from their neighbours (docs/FORMAT.md).
constexpr std::uint32_t kPredictedMeanBrdf = 4;
// The texture models' flag (version 6 on): each image's mean and deviation stored, the CAR
// models solved on the torus (docs/FORMAT.md).
constexpr std::uint32_t kImageMoments = 8;
// With kImageMoments (version 7 on): the moments' codes predicted from their neighbours on the
// light x view grid, as the mixture's mean BRDF is (version 6 stored each less the one before).
constexpr std::uint32_t kPredictedImageMoments = 16;
// With both (version 8 on): each subspace's relief structure stored, added to its synthesis.
constexpr std::uint32_t kReliefStructure = 32;
// The flags a mixture's file is written with.
std::uint32_t mixture_file_flags(const BtfModel& model);
// The Gaussian mixture's method tag.
constexpr std::string_view kMixtureMethod = "gm";

// A model file checked (magic, version, size, CRC-32, flags) and split into its method tag,
// its provenance (none recorded before version 3, or where the writer had none) and that
// method's payload (a view into the bytes given).
struct ModelFileContents {
  std::uint32_t version = 0, flags = 0;
  std::string method;
  Provenance provenance;
  std::span<const std::uint8_t> payload;
};
// Throws Error(kFormat) naming `name` for an empty, truncated, corrupted or newer-version
// file, a malformed method tag or a malformed provenance.
ModelFileContents open_model_file(std::span<const std::uint8_t> bytes, const std::string& name);
// The whole file (the current version): header, method tag, provenance (an empty section
// when not recorded), payload, CRC-32.
std::vector<std::uint8_t> model_file_bytes(std::string_view method, std::uint32_t flags,
                                           const Provenance& provenance,
                                           std::span<const std::uint8_t> payload);

// The Gaussian mixture's payload (everything after the method tag).
std::vector<std::uint8_t> mixture_payload(const BtfModel& model);
BtfModel read_mixture_payload(std::span<const std::uint8_t> payload, std::uint32_t flags,
                              const std::string& name);

std::vector<std::uint8_t> serialize_model(const BtfModel& model);
// Throws Error(kFormat) naming `name` for a truncated, corrupted or newer-version file, or a
// file of another method. The model's provenance is the file's.
BtfModel deserialize_model(std::span<const std::uint8_t> bytes, const std::string& name);

// Atomic: written to a temporary file in the same folder, flushed, then renamed.
void save_model(const BtfModel& model, const std::filesystem::path& path);
BtfModel load_model(const std::filesystem::path& path);

}  // namespace btfgmm
