// libFuzzer target: the model-file reader (docs/FORMAT.md) on arbitrary bytes. Every input
// must either be read or be refused with btfgmm::Error; anything else (a crash, a sanitizer
// report, another exception) is a bug. A model that is read must evaluate and round-trip.
//
// Each input is read twice: as given (the header, version and CRC checks), and with its
// payload size and CRC-32 made right, so that mutations reach the fields behind the checksum.
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"

namespace {

void read_and_use(std::span<const std::uint8_t> bytes) {
  btfgmm::BtfModel m;
  try {
    m = btfgmm::deserialize_model(bytes, "fuzz.btfgmm");
  } catch (const btfgmm::Error&) {
    return;
  }
  // Evaluation: the conditional weights and the mean BRDF interpolated over the model's own
  // direction sets, at a measured pair and between pairs.
  btfgmm::Query q;
  q.x = 0.5;
  q.y = -3.25;
  q.light = m.lights[0];
  q.view = m.views[m.views.size() - 1];
  (void)btfgmm::predict(m, q);
  q.light = {45.0, 10.0};
  q.view = {89.0, 359.0};
  (void)btfgmm::predict(m, q);
  // Decoding sizes its tables by the tile: only small ones here.
  if (std::size_t(m.width) * std::size_t(m.height) <= 4096)
    (void)btfgmm::decode(m, btfgmm::DirectionSet({m.lights[0]}), btfgmm::DirectionSet({m.views[0]}),
                         2, 3);
  // What is read is written back to the same bytes' meaning.
  const std::vector<std::uint8_t> again = btfgmm::serialize_model(m);
  (void)btfgmm::deserialize_model(again, "fuzz-again.btfgmm");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  read_and_use({data, size});
  // The same bytes with a consistent payload size (u64 at 16) and CRC-32 (the last 4 bytes).
  if (size >= 28) {
    std::vector<std::uint8_t> fixed(data, data + size);
    const std::uint64_t payload = size - 28;
    std::memcpy(fixed.data() + 16, &payload, 8);
    const auto crc = std::uint32_t(crc32(0L, fixed.data(), uInt(size - 4)));
    std::memcpy(fixed.data() + size - 4, &crc, 4);
    read_and_use(fixed);
  }
  return 0;
}
