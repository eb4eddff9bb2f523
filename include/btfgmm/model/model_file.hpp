// The model file (docs/FORMAT.md): versioned, checksummed, written atomically. Version 2
// tags the payload with the method that wrote it (methods/registry.hpp reads any method);
// version 1 files hold a Gaussian mixture and are read as such.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/model/model.hpp"

namespace btfgmm {

constexpr std::uint32_t kModelFormatVersion = 2;
// The Gaussian mixture's method tag.
constexpr std::string_view kMixtureMethod = "gm";

// A model file checked (magic, version, size, CRC-32, flags) and split into its method tag
// and that method's payload (a view into the bytes given).
struct ModelFileContents {
  std::uint32_t version = 0, flags = 0;
  std::string method;
  std::span<const std::uint8_t> payload;
};
// Throws Error(kFormat) naming `name` for an empty, truncated, corrupted or newer-version
// file, or a malformed method tag.
ModelFileContents open_model_file(std::span<const std::uint8_t> bytes, const std::string& name);
// The whole file: header, method tag, payload, CRC-32.
std::vector<std::uint8_t> model_file_bytes(std::string_view method, std::uint32_t flags,
                                           std::span<const std::uint8_t> payload);

// The Gaussian mixture's payload (everything after the method tag).
std::vector<std::uint8_t> mixture_payload(const BtfModel& model);
BtfModel read_mixture_payload(std::span<const std::uint8_t> payload, std::uint32_t flags,
                              const std::string& name);

std::vector<std::uint8_t> serialize_model(const BtfModel& model);
// Throws Error(kFormat) naming `name` for a truncated, corrupted or newer-version file, or a
// file of another method.
BtfModel deserialize_model(std::span<const std::uint8_t> bytes, const std::string& name);

// Atomic: written to a temporary file in the same folder, flushed, then renamed.
void save_model(const BtfModel& model, const std::filesystem::path& path);
BtfModel load_model(const std::filesystem::path& path);

}  // namespace btfgmm
