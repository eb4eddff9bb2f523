// libFuzzer target: the neural fit's checkpoint reader (methods/neural_btf_checkpoint.hpp) on
// arbitrary bytes. Every input must either be read or be refused with btfgmm::Error; a
// checkpoint of the current version that is read must write back to the same bytes.
//
// Each input is read twice: as given (the magic, version and CRC checks), and with its CRC-32
// made right, so that mutations reach the fields behind the checksum.
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
#include "checkpoint_fuzz.hpp"

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
  btfgmm::fuzz::trap_unless_written_back(bytes, again, 2);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  btfgmm::fuzz::as_given_and_with_crc_fixed(data, size, read_and_write_back);
  return 0;
}
