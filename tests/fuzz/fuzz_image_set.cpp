// libFuzzer target: the image readers and the zip reader on arbitrary bytes. Every input must
// be decoded or refused with btfgmm::Error; anything else is a bug.
//
// Each input is given to the header reader and the decoder under the names x.png, x.jpg and
// x.exr (the contents must match the name, so one of them gets past the format check), whole
// and as a tile; an input that starts like a zip ("PK") is also written to a file and opened
// as a Bonn zip, and its images loaded.
//
// The decoder may allocate as much as the machine's memory for a header that claims a huge
// image the data cannot disprove (OpenEXR: any compression can be that good); libFuzzer's
// malloc limit (2 GB) is not the machine's, so such inputs only have their header read here.
#include <omp.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <span>
#include <string>
#include <system_error>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"

namespace {

constexpr std::int64_t kMaxFuzzPixels = std::int64_t(1) << 22;

void decode_as(std::span<const std::uint8_t> bytes, const std::string& name) {
  try {
    const btfgmm::ImageHeader h = btfgmm::decode_image_header(bytes, name);
    if (std::int64_t(h.width) * h.height > kMaxFuzzPixels) return;
    const btfgmm::Image whole = btfgmm::decode_image(bytes, name);
    if (whole.width != h.width || whole.height != h.height ||
        whole.rgb.size() != std::size_t(h.width) * std::size_t(h.height) * 3)
      __builtin_trap();  // the decoder disagrees with the header
    const btfgmm::Tile tile{.x = h.width / 3,
                            .y = h.height / 2,
                            .width = (h.width + 1) / 2,
                            .height = (h.height + 1) / 2};
    (void)btfgmm::decode_image(bytes, name, tile);
  } catch (const btfgmm::Error&) {
  }
}

// The zip file of this process, removed at exit.
struct ZipFile {
  std::filesystem::path path = std::filesystem::temp_directory_path() /
                               ("btfgmm_fuzz_" + std::to_string(::getpid()) + ".zip");
  ~ZipFile() {
    std::error_code ec;
    std::filesystem::remove(path, ec);
  }
};

void open_zip(std::span<const std::uint8_t> bytes) {
  static const ZipFile zip;
  const std::filesystem::path& path = zip.path;
  if (std::FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
  }
  try {
    const btfgmm::BtfSource src = btfgmm::BtfSource::open(path);
    const btfgmm::BtfInfo& info = src.info();
    if (std::int64_t(info.width) * info.height > kMaxFuzzPixels) return;
    (void)src.load();
  } catch (const btfgmm::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  omp_set_num_threads(1);  // reproducible runs; the readers' threading is not under test
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  for (const char* name : {"x.png", "x.jpg", "x.exr"}) decode_as(bytes, name);
  if (size >= 2 && data[0] == 'P' && data[1] == 'K') open_zip(bytes);
  return 0;
}
