// The model file (docs/FORMAT.md): versioned, checksummed, written atomically.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/model/model.hpp"

namespace btfgmm {

constexpr std::uint32_t kModelFormatVersion = 1;

std::vector<std::uint8_t> serialize_model(const BtfModel& model);
// Throws Error(kFormat) naming `name` for a truncated, corrupted or newer-version file.
BtfModel deserialize_model(std::span<const std::uint8_t> bytes, const std::string& name);

// Atomic: written to a temporary file in the same folder, flushed, then renamed.
void save_model(const BtfModel& model, const std::filesystem::path& path);
BtfModel load_model(const std::filesystem::path& path);

}  // namespace btfgmm
