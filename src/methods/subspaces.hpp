// The BTF subspaces of Haindl & Filip (PAMI 2007) (internal): the ni * nv images clustered
// by k-means into c groups that look alike, one representative image per group (the member
// nearest its centre) and a label per (light, view).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "btfgmm/core/btf.hpp"

namespace btfgmm::detail {

struct Subspaces {
  std::vector<std::uint8_t> labels;          // per image, light-major (Btf::image_index)
  std::vector<std::size_t> representatives;  // per subspace, an image index
};

// Each image's features (per channel: mean and standard deviation; the luminance's
// correlation with its right and lower neighbour), standardised over the images, clustered
// by k-means (k-means++ seeding from `seed`, Lloyd iterations to a fixed point, at most 50).
// c is capped at the number of images; an emptied cluster is dropped.
Subspaces cluster_images(const Btf& tile, std::size_t c, std::uint64_t seed);

}  // namespace btfgmm::detail
