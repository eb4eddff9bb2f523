// Local PCA by alternating per-cluster PCAs and re-assignment (Kambhatla & Leen 1997).
#include "methods/lpca_fit.hpp"

#include <algorithm>
#include <cassert>
#include <limits>

#include "core/eigen_dense.hpp"
#include "core/random.hpp"
#include "methods/pca_methods.hpp"

namespace btfgmm::detail {
namespace {

using MatD = Eigen::MatrixXd;
using RowMatD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

double squared_distance(const float* a, const float* b, std::size_t dims) {
  double s = 0.0;
  for (std::size_t j = 0; j < dims; ++j) {
    const double d = double(a[j]) - double(b[j]);
    s += d * d;
  }
  return s;
}

// Each cluster's PCA of its texels (an empty cluster has none: the caller refills it first).
std::vector<Pca> cluster_pcas(std::span<const float> x, std::size_t dims,
                              const std::vector<std::uint32_t>& cluster, std::size_t k,
                              std::size_t c, std::uint64_t seed) {
  std::vector<std::vector<std::size_t>> members(k);
  for (std::size_t t = 0; t < cluster.size(); ++t) members[cluster[t]].push_back(t);
  std::vector<Pca> pcas(k);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t a = 0; a < std::ptrdiff_t(k); ++a) {
    const auto& m = members[std::size_t(a)];
    assert(!m.empty());
    std::vector<float> rows(m.size() * dims);
    for (std::size_t i = 0; i < m.size(); ++i)
      std::copy_n(x.data() + m[i] * dims, dims, rows.data() + i * dims);
    PcaSettings ps;
    ps.seed = seed + std::uint64_t(a);
    pcas[std::size_t(a)] = principal_components(rows, m.size(), dims, c, ps);
  }
  return pcas;
}

// Moves every texel to the cluster with the least error (a tie keeps it where it is).
std::size_t reassign(const std::vector<double>& err, std::size_t k,
                     std::vector<std::uint32_t>& cluster) {
  std::size_t moved = 0;
  for (std::size_t t = 0; t < cluster.size(); ++t) {
    std::uint32_t best = cluster[t];
    for (std::size_t a = 0; a < k; ++a)
      if (err[t * k + a] < err[t * k + best]) best = std::uint32_t(a);
    if (best != cluster[t]) ++moved;
    cluster[t] = best;
  }
  return moved;
}

// Gives each empty cluster the texel worst reconstructed in a cluster of two or more.
std::size_t refill_empty(const std::vector<double>& err, std::size_t k,
                         std::vector<std::uint32_t>& cluster) {
  std::vector<std::size_t> count(k, 0);
  for (std::uint32_t a : cluster) ++count[a];
  std::size_t moved = 0;
  for (std::size_t a = 0; a < k; ++a) {
    if (count[a] > 0) continue;
    std::size_t worst = cluster.size();
    for (std::size_t t = 0; t < cluster.size(); ++t)
      if (count[cluster[t]] > 1 &&
          (worst == cluster.size() || err[t * k + cluster[t]] > err[worst * k + cluster[worst]]))
        worst = t;
    assert(worst < cluster.size());  // k <= texels
    --count[cluster[worst]];
    cluster[worst] = std::uint32_t(a);
    ++count[a];
    ++moved;
  }
  return moved;
}

}  // namespace

std::vector<float> texel_brdfs(const Btf& tile) {
  const std::size_t texels = std::size_t(tile.width()) * std::size_t(tile.height()),
                    pairs = tile.image_count(), dims = pairs * 3;
  std::vector<float> x(texels * dims);
  for (std::size_t p = 0; p < pairs; ++p) {
    const float* image = tile.data().data() + p * tile.image_floats();
    for (std::size_t t = 0; t < texels; ++t)
      for (std::size_t ch = 0; ch < 3; ++ch) x[t * dims + p * 3 + ch] = image[t * 3 + ch];
  }
  return x;
}

std::vector<double> reconstruction_errors(std::span<const float> x, std::size_t texels,
                                          std::size_t dims, const std::vector<Pca>& pcas) {
  const std::size_t k = pcas.size();
  std::vector<double> err(texels * k);
  const std::size_t step = std::max<std::size_t>(1, (std::size_t(1) << 20) / dims);
  const Eigen::Map<const RowMatF> xs(x.data(), Eigen::Index(texels), Eigen::Index(dims));
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t b = 0; b < std::ptrdiff_t((texels + step - 1) / step); ++b) {
    const std::size_t t0 = std::size_t(b) * step, n = std::min(step, texels - t0);
    const MatD block = xs.middleRows(Eigen::Index(t0), Eigen::Index(n)).cast<double>();
    for (std::size_t a = 0; a < k; ++a) {
      const Pca& p = pcas[a];
      // |x - m|² - |B (x - m)|²: the residual's energy off the cluster's orthonormal basis.
      const MatD r =
          block.rowwise() - Eigen::Map<const Eigen::RowVectorXd>(p.mean.data(), Eigen::Index(dims));
      const MatD proj = r * Eigen::Map<const RowMatD>(
                                p.directions.data(), Eigen::Index(p.components), Eigen::Index(dims))
                                .transpose();
      for (std::size_t i = 0; i < n; ++i)
        err[(t0 + i) * k + a] = std::max(
            0.0, r.row(Eigen::Index(i)).squaredNorm() - proj.row(Eigen::Index(i)).squaredNorm());
    }
  }
  return err;
}

std::vector<std::uint32_t> seed_clusters(std::span<const float> x, std::size_t texels,
                                         std::size_t dims, std::size_t k, std::uint64_t seed) {
  assert(k >= 1 && k <= texels);
  SplitMix64 rng(mix64(seed ^ 0x4C504341ULL));
  std::vector<std::size_t> seeds = {
      std::min(texels - 1, std::size_t(rng.uniform() * double(texels)))};
  std::vector<double> d2(texels);
  for (std::size_t t = 0; t < texels; ++t)
    d2[t] = squared_distance(x.data() + t * dims, x.data() + seeds[0] * dims, dims);
  while (seeds.size() < k) {
    double total = 0.0;
    for (double v : d2) total += v;
    std::size_t next = 0;
    if (total > 0.0) {  // a texel with probability proportional to d²
      const double r = rng.uniform() * total;
      double sum = 0.0;
      while (next + 1 < texels && (sum += d2[next]) <= r) ++next;
      while (d2[next] == 0.0) --next;  // round-off past the end: the last texel with d² > 0
    } else {                           // every texel repeats a seed: the first not yet taken
      while (std::find(seeds.begin(), seeds.end(), next) != seeds.end()) ++next;
    }
    seeds.push_back(next);
    for (std::size_t t = 0; t < texels; ++t)
      d2[t] = std::min(d2[t], squared_distance(x.data() + t * dims, x.data() + next * dims, dims));
  }
  std::vector<std::uint32_t> cluster(texels, 0);
  for (std::size_t t = 0; t < texels; ++t) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < k; ++a) {
      const double d = squared_distance(x.data() + t * dims, x.data() + seeds[a] * dims, dims);
      if (d < best) best = d, cluster[t] = std::uint32_t(a);
    }
  }
  return cluster;
}

LocalPca fit_local_pca(std::span<const float> x, std::size_t texels, std::size_t dims,
                       std::size_t k, std::size_t c, int max_rounds, const FitOptions& s) {
  LocalPca l;
  l.texels = texels;
  l.dims = dims;
  l.clusters = k;
  l.components = c;
  l.cluster = seed_clusters(x, texels, dims, k, s.seed);
  // The nearest-seed assignment may leave a cluster empty where texels repeat.
  refill_empty(std::vector<double>(texels * k, 0.0), k, l.cluster);
  while (l.rounds < max_rounds) {
    check_stop(s, "lpca");
    report(s, double(l.rounds) / double(max_rounds), "local PCA: cluster PCAs, re-assignment");
    l.pcas = cluster_pcas(x, dims, l.cluster, k, c, s.seed);
    ++l.rounds;
    const std::vector<double> err = reconstruction_errors(x, texels, dims, l.pcas);
    double total = 0.0;
    for (std::size_t t = 0; t < texels; ++t) total += err[t * k + l.cluster[t]];
    l.errors.push_back(total);
    std::size_t moved = reassign(err, k, l.cluster);
    moved += refill_empty(err, k, l.cluster);
    if (moved == 0) {
      l.converged = true;
      return l;
    }
  }
  // Out of rounds: the PCAs of the clusters as they now are.
  l.pcas = cluster_pcas(x, dims, l.cluster, k, c, s.seed);
  return l;
}

}  // namespace btfgmm::detail
