// The PCA methods: the shared principal components (methods/pca.hpp), PCA BTF (Koudelka et
// al. 2003), PCA RF (Sattler et al. 2003) and LPCA (Mueller et al. 2003).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/random.hpp"
#include "methods/pca.hpp"

namespace btfgmm {
namespace {

// rows x cols values: a rank-`rank` matrix with decaying singular values, an offset per
// column and a little noise, deterministic from the seed.
std::vector<float> structured_matrix(std::size_t rows, std::size_t cols, std::size_t rank,
                                     double noise, std::uint64_t seed) {
  detail::SplitMix64 rng(seed);
  std::vector<double> u(rows * rank), v(rank * cols), offset(cols);
  for (double& x : u) x = rng.uniform(-1.0, 1.0);
  for (double& x : v) x = rng.uniform(-1.0, 1.0);
  for (double& x : offset) x = rng.uniform(0.0, 100.0);
  std::vector<float> m(rows * cols);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) {
      double s = offset[j] + noise * rng.uniform(-1.0, 1.0);
      for (std::size_t k = 0; k < rank; ++k)
        s += 40.0 / double(k + 1) * u[i * rank + k] * v[k * cols + j];
      m[i * cols + j] = float(s);
    }
  return m;
}

double squared_error(const std::vector<float>& x, const std::vector<double>& r) {
  double e = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) e += (double(x[i]) - r[i]) * (double(x[i]) - r[i]);
  return e;
}

double squared_norm(const std::vector<float>& x) {
  double e = 0.0;
  for (float v : x) e += double(v) * double(v);
  return e;
}

// The largest |D Dᵀ - I| of the directions.
double orthonormality_error(const detail::Pca& p) {
  double worst = 0.0;
  for (std::size_t a = 0; a < p.components; ++a)
    for (std::size_t b = 0; b < p.components; ++b) {
      double dot = 0.0;
      for (std::size_t j = 0; j < p.cols; ++j)
        dot += p.directions[a * p.cols + j] * p.directions[b * p.cols + j];
      worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
    }
  return worst;
}

TEST(PcaCore, FullRankReproducesTheData) {
  // Centred, the rank is at most rows - 1; without the mean, rows.
  for (const auto& [rows, cols] : {std::pair<std::size_t, std::size_t>{12, 30}, {30, 12}}) {
    const auto x = structured_matrix(rows, cols, 40, 1.0, 3);
    detail::PcaSettings s;
    const std::size_t full = std::min(rows - 1, cols);
    const detail::Pca p = detail::principal_components(x, rows, cols, full, s);
    EXPECT_LT(squared_error(x, detail::reconstruct(p)), 1e-18 * squared_norm(x) * double(x.size()))
        << rows << " x " << cols;
    EXPECT_LT(p.discarded_energy, 1e-9 * p.total_energy);
    s.centre = false;
    const detail::Pca q = detail::principal_components(x, rows, cols, std::min(rows, cols), s);
    EXPECT_LT(squared_error(x, detail::reconstruct(q)), 1e-18 * squared_norm(x) * double(x.size()));
    EXPECT_LT(orthonormality_error(p), 1e-12);
    EXPECT_LT(orthonormality_error(q), 1e-12);
  }
}

TEST(PcaCore, ErrorIsTheDiscardedEnergy) {
  for (const auto& [rows, cols] : {std::pair<std::size_t, std::size_t>{20, 45}, {45, 20}}) {
    const auto x = structured_matrix(rows, cols, 8, 2.0, 5);
    for (std::size_t c : {1, 3, 7}) {
      const detail::Pca p = detail::principal_components(x, rows, cols, c);
      EXPECT_NEAR(squared_error(x, detail::reconstruct(p)), p.discarded_energy,
                  1e-9 * p.total_energy);
      double tail = 0.0;
      for (std::size_t i = c; i < p.singular_values.size(); ++i)
        tail += p.singular_values[i] * p.singular_values[i];
      EXPECT_DOUBLE_EQ(tail, p.discarded_energy);
      EXPECT_EQ(p.singular_values.size(), std::min(rows, cols));
      EXPECT_FALSE(p.randomized);
    }
  }
}

TEST(PcaCore, RandomizedAgreesWithTheGramMatrix) {
  const std::size_t rows = 150, cols = 120;
  const auto x = structured_matrix(rows, cols, 6, 0.5, 7);
  detail::PcaSettings s;
  s.randomized_above = 50;
  const detail::Pca r = detail::principal_components(x, rows, cols, 4, s);
  const detail::Pca g = detail::principal_components(x, rows, cols, 4);
  EXPECT_TRUE(r.randomized);
  EXPECT_FALSE(g.randomized);
  EXPECT_LT(orthonormality_error(r), 1e-12);
  EXPECT_NEAR(r.discarded_energy, g.discarded_energy, 1e-8 * g.discarded_energy);
  EXPECT_NEAR(squared_error(x, detail::reconstruct(r)), r.discarded_energy, 1e-9 * r.total_energy);
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_NEAR(r.singular_values[i], g.singular_values[i], 1e-9 * g.singular_values[0]);
}

TEST(PcaCore, MoreComponentsThanRowsCompleteTheBasis) {
  const auto x = structured_matrix(5, 20, 5, 1.0, 9);
  const detail::Pca p = detail::principal_components(x, 5, 20, 8);
  EXPECT_EQ(p.components, 8u);
  EXPECT_LT(orthonormality_error(p), 1e-12);
  EXPECT_LT(squared_error(x, detail::reconstruct(p)), 1e-18 * squared_norm(x) * double(x.size()));
}

TEST(PcaCore, FitCoordinatesProjectOnAnOrthonormalBasis) {
  const auto x = structured_matrix(30, 16, 6, 1.0, 11);
  const detail::Pca p = detail::principal_components(x, 30, 16, 3);
  const std::vector<float> mean(p.mean.begin(), p.mean.end()),
      basis(p.directions.begin(), p.directions.end());
  const auto w = detail::fit_coordinates(x, 30, 16, mean, basis, 3);
  for (std::size_t i = 0; i < w.size(); ++i) EXPECT_NEAR(w[i], p.coordinates[i], 1e-4);
  // A basis that is not orthonormal: the fit still minimises the error (the same span).
  std::vector<float> skew = basis;
  for (std::size_t j = 0; j < 16; ++j) skew[16 + j] += 0.5f * basis[j];
  const auto ws = detail::fit_coordinates(x, 30, 16, mean, skew, 3);
  std::vector<double> r(30 * 16);
  for (std::size_t i = 0; i < 30; ++i)
    for (std::size_t j = 0; j < 16; ++j) {
      double s = mean[j];
      for (std::size_t k = 0; k < 3; ++k) s += ws[i * 3 + k] * double(skew[k * 16 + j]);
      r[i * 16 + j] = s;
    }
  EXPECT_NEAR(squared_error(x, r), p.discarded_energy, 1e-5 * p.total_energy);
}

}  // namespace
}  // namespace btfgmm
