// libFuzzer target: the mixture fit's checkpoint reader (model/checkpoint.hpp) on arbitrary
// bytes. Every input must either be read or be refused with btfgmm::Error; a checkpoint of the
// current version that is read must write back to the same bytes.
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
#include "btfgmm/model/checkpoint.hpp"
#include "checkpoint_fuzz.hpp"

namespace {

std::filesystem::path temporary(const char* what) {
  return std::filesystem::temp_directory_path() /
         ("fuzz_checkpoint_" + std::to_string(::getpid()) + what);
}

std::vector<std::uint8_t> bytes_of(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A checkpoint read from `bytes` (through a file, as the command reads it) and written back.
void read_and_write_back(std::span<const std::uint8_t> bytes) {
  const std::filesystem::path in = temporary(".in.ckpt"), out = temporary(".out.ckpt");
  std::ofstream(in, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  btfgmm::FitCheckpoint c;
  try {
    c = btfgmm::load_checkpoint(in);
  } catch (const btfgmm::Error&) {
    std::filesystem::remove(in);
    return;
  }
  std::filesystem::remove(in);
  btfgmm::save_checkpoint(c, out);
  const std::vector<std::uint8_t> again = bytes_of(out);
  std::filesystem::remove(out);
  btfgmm::fuzz::trap_unless_written_back(bytes, again, 3);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  btfgmm::fuzz::as_given_and_with_crc_fixed(data, size, read_and_write_back);
  return 0;
}
