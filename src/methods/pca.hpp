// Principal components of n vectors of dimension d (standard PCA, as Koudelka et al. 2003,
// Sattler et al. 2003 and Mueller et al. 2003 use it for BTFs): the mean (optional), the top
// c orthonormal principal directions, each vector's coordinates along them, and the singular
// values of the centred data. Shared by pca-btf, pca-rf and lpca.
//
// The decomposition is an eigen-decomposition, in double, of the Gram matrix of the smaller
// side (X Xᵀ, n x n, when n <= d; Xᵀ X, d x d, otherwise); when both sides are large it is a
// randomized SVD (Halko, Martinsson & Tropp 2011: a Gaussian range finder with power
// iterations, seeded; the range finder's products in single precision, the projection and its
// SVD in double). The data is never copied whole: the single-precision products read it as
// it is, the others in blocks centred in double; the result is the same whatever the number
// of threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace btfgmm::detail {

struct PcaSettings {
  bool centre = true;      // subtract the mean vector first
  std::uint64_t seed = 1;  // the randomized path's Gaussian test matrix
  // Both sides above this (and c well below them): the randomized SVD.
  std::size_t randomized_above = 2000;
  int power_iterations = 4;
  // The Gram matrix's eigen-decomposition of the last PCA of the same data (its content, shape
  // and centring) reused, when its side is at most 2048: the same bits as computing it again,
  // at the cost of a hash of the data and at most 32 MiB held until other data replaces it.
  bool reuse_gram = true;
};

struct Pca {
  std::size_t rows = 0, cols = 0, components = 0;
  std::vector<double> mean;         // cols values; zeros when not centred
  std::vector<double> directions;   // components x cols, row-major, orthonormal rows
  std::vector<double> coordinates;  // rows x components, row-major: projections on them
  // Singular values of the centred data, largest first: all min(rows, cols) of them from the
  // Gram matrix, the leading ones found by the randomized path.
  std::vector<double> singular_values;
  double total_energy = 0.0;      // squared Frobenius norm of the centred data
  double discarded_energy = 0.0;  // the sum of the squared discarded singular values
  bool randomized = false;
};

// The PCA of `x` (rows x cols, row-major) with `components` directions (1 <= components <=
// cols; more than rows is allowed: the extra directions complete an orthonormal set and carry
// no energy). The reconstruction mean + coordinates x directions leaves a squared error of
// discarded_energy (the Eckart-Young theorem).
Pca principal_components(std::span<const float> x, std::size_t rows, std::size_t cols,
                         std::size_t components, const PcaSettings& s = {});

// The reconstruction mean + coordinates x directions, rows x cols, in double.
std::vector<double> reconstruct(const Pca& p);

// Least-squares coordinates (rows x c, row-major) of the rows of `x` (rows x cols) against
// `mean` (cols values) and the rows of `basis` (c x cols), which need not be orthonormal (the
// stored, quantised factors): the minimiser of |x - mean - w basis|² for each row.
std::vector<double> fit_coordinates(std::span<const float> x, std::size_t rows, std::size_t cols,
                                    std::span<const float> mean, std::span<const float> basis,
                                    std::size_t c);

}  // namespace btfgmm::detail
