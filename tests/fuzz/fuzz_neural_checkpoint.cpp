// libFuzzer target: the neural fit's checkpoint reader (methods/neural_btf_checkpoint.hpp) on
// arbitrary bytes. Every input must either be read or be refused with btfgmm::Error; a
// checkpoint of the current version that is read must write back to the same bytes.
//
// Each input is read twice: as given (the magic, version and CRC checks), and with its CRC-32
// made right, so that mutations reach the fields behind the checksum.
#include <zlib.h>

#include <unistd.h>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/neural_btf_checkpoint.hpp"

namespace {

// A checkpoint read from `bytes` written to a file and read back as those bytes.
void read_and_write_back(std::span<const std::uint8_t> bytes) {
  btfgmm::NeuralCheckpoint c;
  try {
    c = btfgmm::read_neural_checkpoint(bytes, "fuzz.ckpt");
  } catch (const btfgmm::Error&) {
    return;
  }
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("fuzz_neural_" + std::to_string(::getpid()) + ".ckpt");
  btfgmm::save_neural_checkpoint(c, path);
  std::ifstream in(path, std::ios::binary);
  const std::vector<std::uint8_t> again((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  std::filesystem::remove(path);
  std::uint32_t version = 0;  // an older version's is read, and written back as the current
  std::memcpy(&version, bytes.data() + 8, 4);
  if (version == 2 &&
      (again.size() != bytes.size() || std::memcmp(again.data(), bytes.data(), bytes.size()) != 0))
    __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  read_and_write_back({data, size});
  if (size >= 16) {  // the same bytes with a consistent CRC-32 (the last 4 bytes)
    std::vector<std::uint8_t> fixed(data, data + size);
    const auto crc = std::uint32_t(crc32(0L, fixed.data(), uInt(size - 4)));
    std::memcpy(fixed.data() + size - 4, &crc, 4);
    read_and_write_back(fixed);
  }
  return 0;
}
