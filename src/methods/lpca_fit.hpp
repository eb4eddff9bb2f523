// Local PCA (Kambhatla & Leen 1997, "Dimension reduction by local principal component
// analysis"), as Mueller, Meseth & Klein 2003 apply it to a BTF's texels: the texels' apparent
// BRDFs are clustered, each cluster gets its own PCA (mean + c components), every texel moves
// to the cluster that reconstructs it with the least squared error, and the two steps repeat
// until no texel moves.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/methods/representation.hpp"
#include "methods/pca.hpp"

namespace btfgmm::detail {

// The tile's apparent BRDFs: row t = y * W + x holds texel (x, y)'s ni * nv * 3 values, at
// (light * nv + view) * 3 + channel.
std::vector<float> texel_brdfs(const Btf& tile);

struct LocalPca {
  std::size_t texels = 0, dims = 0, clusters = 0, components = 0;
  std::vector<std::uint32_t> cluster;  // each texel's
  std::vector<Pca> pcas;               // each cluster's, of its texels
  // The total squared error of the texels in their clusters after each round's PCAs: it never
  // grows.
  std::vector<double> errors;
  int rounds = 0;          // PCA fits of all clusters
  bool converged = false;  // the last round moved no texel
};

// Squared errors of reconstructing every row of `x` (texels x dims) with every cluster's mean
// and orthonormal components: texels x clusters, row-major.
std::vector<double> reconstruction_errors(std::span<const float> x, std::size_t texels,
                                          std::size_t dims, const std::vector<Pca>& pcas);

// k-means++ seeds (Arthur & Vassilvitskii 2007), deterministic from `seed`, and every row's
// nearest seed.
std::vector<std::uint32_t> seed_clusters(std::span<const float> x, std::size_t texels,
                                         std::size_t dims, std::size_t k, std::uint64_t seed);

// The local PCA of the rows of `x` with k clusters (k <= texels) of c components, at most
// `max_rounds` rounds. s.stop and s.progress are honoured (stop: Error(kArgument)).
LocalPca fit_local_pca(std::span<const float> x, std::size_t texels, std::size_t dims,
                       std::size_t k, std::size_t c, int max_rounds, const FitOptions& s);

}  // namespace btfgmm::detail
