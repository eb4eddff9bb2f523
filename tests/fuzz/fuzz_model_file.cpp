// libFuzzer target: the model-file reader of every method (docs/FORMAT.md) on arbitrary bytes.
// Every input must either be read or be refused with btfgmm::Error; anything else (a crash, a
// sanitizer report, another exception) is a bug. A model that is read must evaluate and round-trip,
// its provenance (the section of format 3) unchanged.
//
// Each input is read twice: as given (the header, version and CRC checks), and with its
// payload size and CRC-32 made right, so that mutations reach the fields behind the checksum.
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/methods/representation.hpp"
#include "btfgmm/model/provenance.hpp"

namespace {

// `b`, the provenance `a` read back after it was written: the same but for the times, which
// the writer writes as 0 (docs/FORMAT.md, "Provenance": a file records no time).
bool same_provenance(const btfgmm::Provenance& a, const btfgmm::Provenance& b) {
  if (a.recorded != b.recorded || a.data.source.name != b.data.source.name ||
      a.data.source.image_width != b.data.source.image_width ||
      a.data.source.image_height != b.data.source.image_height ||
      a.data.content_hash != b.data.content_hash || a.fit.settings != b.fit.settings ||
      (b.recorded && b.fit.seconds != 0.0) || a.fit.runs != b.fit.runs ||
      a.fit.iterations.size() != b.fit.iterations.size())
    return false;
  for (std::size_t i = 0; i < a.fit.iterations.size(); ++i)
    if (a.fit.iterations[i].log_likelihood != b.fit.iterations[i].log_likelihood ||
        b.fit.iterations[i].seconds != 0.0 ||
        a.fit.iterations[i].components != b.fit.iterations[i].components)
      return false;
  return true;
}

// Any method's model (methods/registry.hpp): read, evaluated at a measured pair and between
// pairs, decoded small, and written back to bytes that read again.
void read_and_use(std::span<const std::uint8_t> bytes) {
  std::unique_ptr<btfgmm::Representation> m;
  try {
    m = btfgmm::read_representation(bytes, "fuzz.btfgmm");
  } catch (const btfgmm::Error&) {
    return;
  }
  const btfgmm::ModelFrame& f = m->frame();
  btfgmm::Query q[2];
  q[0].x = 0.5;
  q[0].y = -3.25;
  q[0].light = f.lights[0];
  q[0].view = f.views[f.views.size() - 1];
  q[1].light = {45.0, 10.0};
  q[1].view = {89.0, 359.0};
  float rgb[6];
  m->predict(q, rgb);
  // Decoding sizes its tables by the tile: only small ones here.
  if (f.pixels() <= 4096)
    (void)m->decode(btfgmm::DirectionSet({f.lights[0]}), btfgmm::DirectionSet({f.views[0]}), 2, 3,
                    1e-3);
  const std::vector<std::uint8_t> again = btfgmm::representation_file_bytes(*m);
  const auto back = btfgmm::read_representation(again, "fuzz-again.btfgmm");
  if (!same_provenance(m->provenance(), back->provenance())) __builtin_trap();
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
