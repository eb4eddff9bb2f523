// The benchmarks' sample set: a generated corduroy BTF of size x size pixels (81 x 81
// directions, seed 1), its tile x tile tile at the origin.
#pragma once

#include "btfgmm/core/btf.hpp"
#include "btfgmm/model/samples.hpp"
#include "btfgmm/synth/generate.hpp"

namespace bench {

inline btfgmm::Btf corduroy_btf(int size) {
  btfgmm::GenerateConfig g;
  g.material = "corduroy";
  g.size = size;
  g.seed = 1;
  return btfgmm::generate(g);
}

inline btfgmm::SampleSet corduroy_samples(int size, int tile) {
  const btfgmm::Btf full = corduroy_btf(size);
  if (tile == size) return btfgmm::make_sample_set(full);  // no copy of the whole BTF
  btfgmm::Btf cut(full.lights(), full.views(), tile, tile, full.format());
  for (std::size_t l = 0; l < full.lights().size(); ++l)
    for (std::size_t v = 0; v < full.views().size(); ++v)
      for (int y = 0; y < tile; ++y)
        for (int x = 0; x < tile; ++x)
          for (int c = 0; c < 3; ++c) cut.at(l, v, x, y, c) = full.at(l, v, x, y, c);
  return btfgmm::make_sample_set(cut);
}

}  // namespace bench
