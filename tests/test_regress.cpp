// Inputs the fuzzers (scripts/fuzz, tests/fuzz/) found crashing, kept in tests/data/regress/:
// each must now be refused with a btfgmm::Error that names it. And every file there goes
// through every reader the fuzz targets drive, which must refuse it cleanly or read it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"

#include "test_util.hpp"

namespace {

namespace fs = std::filesystem;

const fs::path kRegress = fs::path(BTFGMM_TEST_DATA) / "regress";

std::vector<std::uint8_t> bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

using btfgmm::test::error_of;

// A JPEG whose Huffman table claims 551 codes: Debian's stb_image wrote past its tables (in
// the header reader as in the decoder). Found by fuzz_image_set in its first seconds.
TEST(Regress, JpegHuffmanTableOfMoreThan256Codes) {
  const auto bytes = bytes_of(kRegress / "jpeg_huffman_551_codes.jpg");
  ASSERT_FALSE(bytes.empty());
  for (const auto& read :
       {+[](std::span<const std::uint8_t> b) { btfgmm::decode_image_header(b, "r.jpg"); },
        +[](std::span<const std::uint8_t> b) { btfgmm::decode_image(b, "r.jpg"); }}) {
    const std::string msg = error_of([&] { read(bytes); });
    EXPECT_NE(msg.find("r.jpg is a corrupt JPEG (a Huffman table holds 551 codes, at most 256"),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("re-copy or re-export the file"), std::string::npos) << msg;
  }
  const std::string msg =
      error_of([] { btfgmm::read_image_header(kRegress / "jpeg_huffman_551_codes.jpg"); });
  EXPECT_NE(msg.find("jpeg_huffman_551_codes.jpg"), std::string::npos) << msg;
}

// Every regression input through every reader, as the fuzz targets drive them: read, or
// refused with a btfgmm::Error; never another exception (nor a sanitizer report).
TEST(Regress, EveryInputIsReadOrRefusedCleanly) {
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(kRegress)) {
    const auto bytes = bytes_of(entry.path());
    ++files;
    SCOPED_TRACE(entry.path().string());
    for (const char* name : {"x.png", "x.jpg", "x.exr"}) {
      try {
        const btfgmm::ImageHeader h = btfgmm::decode_image_header(bytes, name);
        if (std::int64_t(h.width) * h.height <= (std::int64_t(1) << 22))
          (void)btfgmm::decode_image(bytes, name);
      } catch (const btfgmm::Error&) {
      }
    }
    try {
      (void)btfgmm::deserialize_model(bytes, entry.path().string());
    } catch (const btfgmm::Error&) {
    }
    if (bytes.size() >= 2 && bytes[0] == 'P' && bytes[1] == 'K') {
      try {
        (void)btfgmm::BtfSource::open(entry.path()).load();
      } catch (const btfgmm::Error&) {
      }
    }
  }
  EXPECT_GE(files, 1u);
}

}  // namespace
