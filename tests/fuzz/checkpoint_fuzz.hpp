// What the checkpoint readers' fuzz targets (fuzz_checkpoint, fuzz_neural_checkpoint) share:
// each input read as given and with its CRC-32 made right, and a read checkpoint of the
// current version written back to the same bytes.
#pragma once

#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

namespace btfgmm::fuzz {

// read(bytes) on the input, then on the same bytes with a consistent CRC-32 in the last 4
// (so that mutations reach the fields behind the checksum).
template <class Read>
void as_given_and_with_crc_fixed(const std::uint8_t* data, std::size_t size, Read read) {
  read(std::span<const std::uint8_t>(data, size));
  if (size < 16) return;
  std::vector<std::uint8_t> fixed(data, data + size);
  const auto crc = std::uint32_t(crc32(0L, fixed.data(), uInt(size - 4)));
  std::memcpy(fixed.data() + size - 4, &crc, 4);
  read(std::span<const std::uint8_t>(fixed));
}

// Traps unless `again` (what the checkpoint read from `bytes` writes) is `bytes`, for a
// checkpoint of `version` (its 4 bytes after the 8-byte magic); an older version's is read and
// written back as the current one.
inline void trap_unless_written_back(std::span<const std::uint8_t> bytes,
                                     const std::vector<std::uint8_t>& again,
                                     std::uint32_t version) {
  std::uint32_t was = 0;
  std::memcpy(&was, bytes.data() + 8, 4);
  if (was == version &&
      (again.size() != bytes.size() || std::memcmp(again.data(), bytes.data(), bytes.size()) != 0))
    __builtin_trap();
}

}  // namespace btfgmm::fuzz
