// libFuzzer target: the Bonn .btf reader (io/ubo_btf.hpp) on arbitrary bytes. Every input must
// be read and decoded or refused with btfgmm::Error; anything else is a bug.
//
// An input that opens is decoded whole: its header's sizes are checked against the bytes it
// has, so the factors (and the decoded images) are bounded by the input's size. Every pair of
// the first and last view is decoded, so that the rows of U the decoder takes are checked.
#include <omp.h>

#include <cstdint>
#include <span>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/ubo_btf.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  omp_set_num_threads(1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const btfgmm::UboBtf b = btfgmm::UboBtf::from_bytes({data, data + size}, "x.btf");
    const btfgmm::UboBtfHeader& h = b.header();
    const btfgmm::UboTileFactors f = b.load_tile({});
    std::vector<float> rgb(std::size_t(h.width) * std::size_t(h.height) * 3);
    for (std::size_t v : {std::size_t(0), h.views.size() - 1})
      for (std::size_t l = 0; l < h.lights.size(); ++l) b.decode(f, l, v, rgb);
  } catch (const btfgmm::Error&) {
  }
  return 0;
}
