// Inputs the fuzzers (scripts/fuzz, tests/fuzz/) found crashing, kept in tests/data/regress/:
// each must now be refused with a btfgmm::Error that names it. And every file there goes
// through every reader the fuzz targets drive, which must refuse it cleanly or read it.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/model/checkpoint.hpp"
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

// A 4 x 4 OpenEXR image (one chunk of ZIP-compressed scanlines) whose line offset table
// points its chunk at `offset`. The table follows the header; its one entry is the offset of
// the chunk right behind it, so the table is where the file holds its own position + 8.
std::vector<std::uint8_t> exr_with_chunk_at(std::uint64_t offset) {
  const fs::path path =
      fs::temp_directory_path() / ("btfgmm_regress_" + std::to_string(::getpid()) + ".exr");
  btfgmm::write_exr(path, 4, 4, std::vector<float>(4 * 4 * 3, 0.5f));
  std::vector<std::uint8_t> bytes = bytes_of(path);
  fs::remove(path);
  for (std::size_t at = 8; at + 8 <= bytes.size(); ++at) {
    std::uint64_t v;
    std::memcpy(&v, bytes.data() + at, 8);
    if (v == at + 8) {
      std::memcpy(bytes.data() + at, &offset, 8);
      return bytes;
    }
  }
  ADD_FAILURE() << "no line offset table in the OpenEXR image";
  return bytes;
}

// An OpenEXR image whose line offset table points its chunk near the top of the 64-bit range:
// the in-memory stream's end check (position + length > size) wrapped around, and it copied
// from before the file's bytes. Found by fuzz_image_set in a 5-minute run; the same with an
// offset past the end of the file, which must be refused the same way.
TEST(Regress, ExrChunkOffsetPastTheEndOrNearTwoToThe64) {
  const std::uint64_t top = ~std::uint64_t(0);
  for (const std::uint64_t offset : {top, top - 3, top - 7, top - 100, std::uint64_t(1) << 63,
                                     std::uint64_t(1) << 32, std::uint64_t(100000)}) {
    SCOPED_TRACE(offset);
    const auto bytes = exr_with_chunk_at(offset);
    EXPECT_EQ(btfgmm::decode_image_header(bytes, "o.exr").width, 4);
    const std::string msg = error_of([&] { btfgmm::decode_image(bytes, "o.exr"); });
    EXPECT_NE(msg.find("o.exr is not a readable OpenEXR image"), std::string::npos) << msg;
    EXPECT_NE(msg.find(fmt::format("an offset in the file ({}) points past its end ({} bytes)",
                                   offset, bytes.size())),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("re-copy or re-export it"), std::string::npos) << msg;
  }
  // The committed input (tests/data/regress/), through the file reader.
  const fs::path file = kRegress / "exr_chunk_offset_near_2_64.exr";
  const std::string msg = error_of([&] { btfgmm::read_image(file); });
  EXPECT_NE(msg.find("exr_chunk_offset_near_2_64.exr is not a readable OpenEXR image"),
            std::string::npos)
      << msg;
}

// A Bonn zip of 460 bytes whose second entry claims 1,751,318,601 stored bytes and
// 1,953,720,684 inflated (within deflate's ratio of 1032): the reader allocated the 1.95 GB
// before libzip found the bytes missing. Found by fuzz_image_set (out of memory) in a 5-minute
// run. Refused now before anything is allocated, naming the entry and the archive's size.
TEST(Regress, ZipEntryClaimingMoreStoredBytesThanTheArchive) {
  const fs::path file = kRegress / "zip_entry_claims_1751318601_stored_bytes.zip";
  ASSERT_EQ(fs::file_size(file), 460u);
  const std::string msg = error_of([&] { (void)btfgmm::BtfSource::open(file).load(); });
  EXPECT_NE(msg.find("zip_entry_claims_1751318601_stored_bytes.zip:m/00001 tl000 pl000 tv015 "
                     "pv000.png claims 1751318601 stored bytes, more than the archive's 460 "
                     "bytes; the archive is corrupt, download it again"),
            std::string::npos)
      << msg;
}

// Every regression input through every reader, as the fuzz targets drive them: read, or
// refused with a btfgmm::Error; never another exception (nor a sanitizer report).
// A checkpoint (of a made tile) whose converged flag is 13: read as "converged", it wrote back
// as 1, so the file did not round-trip. Found by fuzz_checkpoint in 90,018 executions.
TEST(Regress, CheckpointConvergedFlagNeitherZeroNorOne) {
  const fs::path p = kRegress / "checkpoint_converged_flag_13.ckpt";
  const std::string msg = error_of([&] { btfgmm::load_checkpoint(p); });
  EXPECT_NE(msg.find("converged flag is neither 0 nor 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("checkpoint_converged_flag_13.ckpt"), std::string::npos) << msg;
}

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
    try {
      (void)btfgmm::load_checkpoint(entry.path());
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
