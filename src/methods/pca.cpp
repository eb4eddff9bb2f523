// Principal component analysis by the Gram matrix of the smaller side or by a randomized SVD
// (pca.hpp).
#include "methods/pca.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <memory>
#include <mutex>
#include <type_traits>

#include "btfgmm/model/provenance.hpp"
#include "core/eigen_dense.hpp"
#include "core/random.hpp"
#include "methods/pca_methods.hpp"

namespace btfgmm::detail {
namespace {

using MatD = Eigen::MatrixXd;
template <class T>
using Mat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>;
template <class T>
using RowMat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatF = RowMat<float>;
using RowMatD = RowMat<double>;

// About this many doubles in a block of the data converted for a product.
constexpr std::size_t kBlockValues = std::size_t(1) << 21;

// The mean of the rows of x (rows x cols): fixed slabs of columns over OpenMP's threads, each
// column summed in the rows' order.
Eigen::RowVectorXd column_means(const Eigen::Map<const RowMatF>& x) {
  Eigen::RowVectorXd mean = Eigen::RowVectorXd::Zero(x.cols());
  constexpr Eigen::Index kSlab = 1024;
  const std::ptrdiff_t slabs = std::ptrdiff_t((x.cols() + kSlab - 1) / kSlab);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t k = 0; k < slabs; ++k) {
    const Eigen::Index c0 = Eigen::Index(k) * kSlab, m = std::min(kSlab, x.cols() - c0);
    auto sum = mean.segment(c0, m);
    for (Eigen::Index r = 0; r < x.rows(); ++r) sum += x.row(r).segment(c0, m).cast<double>();
  }
  return mean / double(std::max<Eigen::Index>(1, x.rows()));
}

// The data minus its mean: read as it is (the single-precision products subtract the mean's
// share after), or in blocks of rows or columns centred in double.
class CentredData {
 public:
  CentredData(std::span<const float> x, std::size_t rows, std::size_t cols, bool centre)
      : x_(x.data(), Eigen::Index(rows), Eigen::Index(cols)),
        mean_(centre ? column_means(x_) : Eigen::RowVectorXd::Zero(Eigen::Index(cols))),
        mean_f_(mean_.cast<float>()) {}

  std::span<const float> data() const { return {x_.data(), std::size_t(x_.size())}; }
  std::size_t rows() const { return std::size_t(x_.rows()); }
  std::size_t cols() const { return std::size_t(x_.cols()); }
  const Eigen::RowVectorXd& mean() const { return mean_; }
  const Eigen::RowVectorXf& mean_f() const { return mean_f_; }
  std::size_t row_step() const { return std::max<std::size_t>(1, kBlockValues / cols()); }
  std::size_t col_step() const { return std::max<std::size_t>(1, kBlockValues / rows()); }

  // Rows [r0, r0 + n) and columns [c0, c0 + m) as they are, not centred.
  auto raw_block(std::size_t r0, std::size_t n, std::size_t c0, std::size_t m) const {
    return x_.block(Eigen::Index(r0), Eigen::Index(c0), Eigen::Index(n), Eigen::Index(m));
  }

  // Rows [r0, r0 + n) and columns [c0, c0 + m), centred, into the top-left of `buffer`
  // (which holds at least n x m).
  auto block(std::size_t r0, std::size_t n, std::size_t c0, std::size_t m, RowMatD& buffer) const {
    auto b = buffer.topLeftCorner(Eigen::Index(n), Eigen::Index(m));
    b = raw_block(r0, n, c0, m).cast<double>().rowwise() -
        mean_.segment(Eigen::Index(c0), Eigen::Index(m));
    return b;
  }

  // f(block, first row, rows) for every block of rows [r0, r0 + n), centred, in order; and
  // f(block, first column, columns) for blocks of columns. One buffer serves every block: a
  // pass over the data allocates (and faults in) no new memory.
  template <class F>
  void for_row_blocks(F f) const {
    RowMatD buffer(Eigen::Index(std::min(row_step(), rows())), Eigen::Index(cols()));
    for (std::size_t r0 = 0; r0 < rows(); r0 += row_step()) {
      const Eigen::Index n = Eigen::Index(std::min(row_step(), rows() - r0));
      auto b = buffer.topRows(n);
      b = x_.middleRows(Eigen::Index(r0), n).cast<double>().rowwise() - mean_;
      f(b, Eigen::Index(r0), n);
    }
  }
  template <class F>
  void for_col_blocks(F f) const {
    MatD buffer(Eigen::Index(rows()), Eigen::Index(std::min(col_step(), cols())));
    for (std::size_t c0 = 0; c0 < cols(); c0 += col_step()) {
      const Eigen::Index n = Eigen::Index(std::min(col_step(), cols() - c0));
      auto b = buffer.leftCols(n);
      b = x_.middleCols(Eigen::Index(c0), n).cast<double>().rowwise() -
          mean_.segment(Eigen::Index(c0), n);
      f(b, Eigen::Index(c0), n);
    }
  }

 private:
  Eigen::Map<const RowMatF> x_;
  Eigen::RowVectorXd mean_;
  Eigen::RowVectorXf mean_f_;
};

// a b on the calling thread alone. Eigen's own threads would block the sums by their number,
// and the model must be the same whatever the number of threads.
template <class A, class B>
MatD serial_product(const A& a, const B& b) {
  const ThreadScope one(1);
  return a * b;
}

// Orthonormal columns spanning the leading columns of `v` in order (Householder QR: the first
// j columns of the result span the first j of `v`).
MatD orthonormal_columns(const MatD& v) {
  const ThreadScope one(1);  // as serial_product
  Eigen::HouseholderQR<MatD> qr(v);
  return qr.householderQ() * MatD::Identity(v.rows(), v.cols());
}

// A rows x cols matrix of standard normal values (Box-Muller), deterministic from the seed.
MatD gaussian_matrix(Eigen::Index rows, Eigen::Index cols, std::uint64_t seed) {
  SplitMix64 rng(mix64(seed ^ 0x5043412D52414E44ULL));
  MatD m(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) {
      const double u = 1.0 - rng.uniform(), v = rng.uniform();
      m(i, j) = std::sqrt(-2.0 * std::log(u)) * std::cos(6.283185307179586 * v);
    }
  return m;
}

// The eigenpairs of a symmetric matrix, largest eigenvalue first; negative round-off is 0.
struct Eigenpairs {
  Eigen::VectorXd values;
  MatD vectors;
};
Eigenpairs descending_eigenpairs(const MatD& g) {
  Eigen::SelfAdjointEigenSolver<MatD> es(g);
  Eigenpairs e;
  e.values = es.eigenvalues().reverse().cwiseMax(0.0);
  e.vectors = es.eigenvectors().rowwise().reverse();
  return e;
}

// Rows of a Gram matrix in one of its slabs: fixed, as kSlabColumns below.
constexpr Eigen::Index kGramSlab = 64;

// g += aᵀ a for a block `a` of the data, the slabs of g's rows over OpenMP's threads (each sum
// in the order of the blocks, whatever the number of threads).
template <class Block>
void add_gram(const Block& a, MatD& g) {
  const std::ptrdiff_t slabs = std::ptrdiff_t((g.rows() + kGramSlab - 1) / kGramSlab);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t k = 0; k < slabs; ++k) {
    const Eigen::Index r0 = Eigen::Index(k) * kGramSlab, n = std::min(kGramSlab, g.rows() - r0);
    g.middleRows(r0, n).noalias() += a.middleCols(r0, n).transpose() * a;
  }
}

// The Gram matrix of the columns side, Xcᵀ Xc (cols x cols), and |Xc|².
MatD column_gram(const CentredData& d, double& total) {
  MatD g = MatD::Zero(Eigen::Index(d.cols()), Eigen::Index(d.cols()));
  total = 0.0;
  d.for_row_blocks([&](const auto& b, Eigen::Index, Eigen::Index) {
    add_gram(b, g);
    total += b.squaredNorm();
  });
  return g;
}

// The Gram matrix of the rows side, Xc Xcᵀ (rows x rows), and |Xc|².
MatD row_gram(const CentredData& d, double& total) {
  MatD g = MatD::Zero(Eigen::Index(d.rows()), Eigen::Index(d.rows()));
  total = 0.0;
  d.for_col_blocks([&](const auto& b, Eigen::Index, Eigen::Index) {
    add_gram(b.transpose(), g);
    total += b.squaredNorm();
  });
  return g;
}

// Columns of the data in a slab of transpose_times: fixed, so that its sums do not depend on
// the number of threads.
constexpr std::size_t kSlabColumns = 1024;

// The products below spread fixed pieces of the work over OpenMP's threads; Eigen's products
// inside a parallel region run on the calling thread (its own threads, at 26 columns and on
// shared cores, cost more than they gain). In double each thread centres its own blocks in
// a buffer; in float the products read the data as it is and subtract the mean's share after
// (Xc v = X v - 1 (mean v), Xcᵀ u = Xᵀ u - meanᵀ (1ᵀ u)).

// Xcᵀ u (cols x u.cols()) in T: each slab of columns summed over blocks of rows, in order.
// With `energy` (double only), |Xc|² too (each slab's in order, then the slabs' in order).
template <class T>
Mat<T> transpose_times(const CentredData& d, const Mat<T>& u, double* energy = nullptr) {
  constexpr bool kFloat = std::is_same_v<T, float>;
  assert(!(kFloat && energy));
  Mat<T> out(Eigen::Index(d.cols()), u.cols());
  const std::ptrdiff_t slabs = std::ptrdiff_t((d.cols() + kSlabColumns - 1) / kSlabColumns);
  std::vector<double> slab_energy(std::size_t(slabs), 0.0);
  const Eigen::Matrix<T, 1, Eigen::Dynamic> u_sums = u.colwise().sum();
#pragma omp parallel
  {
    const std::size_t step = std::max<std::size_t>(1, kBlockValues / kSlabColumns);
    RowMat<T> buffer(kFloat ? 0 : Eigen::Index(std::min(step, d.rows())),
                     kFloat ? 0 : Eigen::Index(kSlabColumns));
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t k = 0; k < slabs; ++k) {
      const std::size_t c0 = std::size_t(k) * kSlabColumns,
                        m = std::min(kSlabColumns, d.cols() - c0);
      auto slab = out.middleRows(Eigen::Index(c0), Eigen::Index(m));
      slab.setZero();
      for (std::size_t r0 = 0; r0 < d.rows(); r0 += step) {
        const std::size_t n = std::min(step, d.rows() - r0);
        const auto un = u.middleRows(Eigen::Index(r0), Eigen::Index(n));
        if constexpr (kFloat) {
          slab.noalias() += d.raw_block(r0, n, c0, m).transpose() * un;
        } else {
          const auto b = d.block(r0, n, c0, m, buffer);
          slab.noalias() += b.transpose() * un;
          if (energy) slab_energy[std::size_t(k)] += b.squaredNorm();
        }
      }
      if constexpr (kFloat)
        slab.noalias() -=
            d.mean_f().segment(Eigen::Index(c0), Eigen::Index(m)).transpose() * u_sums;
    }
  }
  if (energy) {
    *energy = 0.0;
    for (double e : slab_energy) *energy += e;
  }
  return out;
}

// Xc v (rows x v.cols()) in T, by blocks of rows, each writing its own rows.
template <class T>
Mat<T> times(const CentredData& d, const Mat<T>& v) {
  constexpr bool kFloat = std::is_same_v<T, float>;
  Mat<T> out(Eigen::Index(d.rows()), v.cols());
  const std::size_t step = d.row_step();
  const std::ptrdiff_t blocks = std::ptrdiff_t((d.rows() + step - 1) / step);
  Eigen::Matrix<T, 1, Eigen::Dynamic> mean_v;
  if constexpr (kFloat) mean_v = d.mean_f() * v;
#pragma omp parallel
  {
    RowMat<T> buffer(kFloat ? 0 : Eigen::Index(std::min(step, d.rows())),
                     kFloat ? 0 : Eigen::Index(d.cols()));
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t k = 0; k < blocks; ++k) {
      const std::size_t r0 = std::size_t(k) * step, n = std::min(step, d.rows() - r0);
      auto o = out.middleRows(Eigen::Index(r0), Eigen::Index(n));
      if constexpr (kFloat) {
        o.noalias() = d.raw_block(r0, n, 0, d.cols()) * v;
        o.rowwise() -= mean_v;
      } else {
        o.noalias() = d.block(r0, n, 0, d.cols(), buffer) * v;
      }
    }
  }
  return out;
}

// `v` (cols x k, k <= c) extended to c orthonormal columns: seeded Gaussian columns appended,
// then orthonormalised in order.
MatD complete_basis(const MatD& v, std::size_t c, std::uint64_t seed) {
  MatD w(v.rows(), Eigen::Index(c));
  w.leftCols(v.cols()) = v;
  if (Eigen::Index(c) > v.cols())
    w.rightCols(Eigen::Index(c) - v.cols()) =
        gaussian_matrix(v.rows(), Eigen::Index(c) - v.cols(), seed + 1);
  return orthonormal_columns(w);
}

// The eigenpairs of the Gram matrix of the smaller side, and |Xc|².
struct GramDecomposition {
  Eigenpairs pairs;
  double total_energy = 0.0;
};

// What a Gram matrix was made of: the data's content hash (provenance.hpp), its shape and
// whether it was centred.
struct GramKey {
  std::uint64_t content = 0;
  std::size_t rows = 0, cols = 0;
  bool centre = false;
  bool operator==(const GramKey&) const = default;
};

// The side of the largest Gram matrix kept by gram_decomposition: 2048² doubles, 32 MiB.
constexpr std::size_t kMostKeptSide = 2048;

// The Gram matrix of the smaller side (Xcᵀ Xc when rows > cols, Xc Xcᵀ otherwise)
// decomposed. The last decomposition of a side up to kMostKeptSide is kept for the next PCA of
// the same data: a sweep or a budget fits PCA BTF at several c on one tile, and the Gram
// matrix and its eigenpairs, most of such a fit's time, do not depend on c. What is kept is
// what would be computed again, so every result is the same bit for bit; it costs one pass
// over the data (its hash) and holds at most 32 MiB until a PCA of other data replaces it.
std::shared_ptr<const GramDecomposition> gram_decomposition(const CentredData& d,
                                                            const PcaSettings& s) {
  static std::mutex mutex;
  static GramKey kept_key;
  static std::shared_ptr<const GramDecomposition> kept;
  const bool keep = s.reuse_gram && std::min(d.rows(), d.cols()) <= kMostKeptSide;
  GramKey key;
  if (keep) {
    key = {content_hash_add(kContentHashBasis, d.data()), d.rows(), d.cols(), s.centre};
    const std::lock_guard lock(mutex);
    if (kept && kept_key == key) return kept;
  }
  auto g = std::make_shared<GramDecomposition>();
  g->pairs = descending_eigenpairs(d.rows() > d.cols() ? column_gram(d, g->total_energy)
                                                       : row_gram(d, g->total_energy));
  if (keep) {
    const std::lock_guard lock(mutex);
    kept_key = key;
    kept = g;
  }
  return g;
}

// The top c right singular vectors (cols x c) from the Gram matrix of the smaller side.
MatD gram_directions(const CentredData& d, std::size_t c, const PcaSettings& s, Pca& p) {
  const std::shared_ptr<const GramDecomposition> g = gram_decomposition(d, s);
  const Eigenpairs& e = g->pairs;
  p.total_energy = g->total_energy;
  p.singular_values.assign(e.values.begin(), e.values.end());
  if (d.rows() > d.cols()) return e.vectors.leftCols(Eigen::Index(c));
  const Eigen::Index k = std::min(Eigen::Index(c), e.values.size());
  // Xcᵀ u_i = s_i v_i: normalised (and re-orthogonalised) by the QR.
  return complete_basis(transpose_times(d, MatD(e.vectors.leftCols(k))), c, s.seed);
}

// An orthonormal basis (rows x l) of the range of Xc Ω, Ω cols x l Gaussian, refined by power
// iterations: the randomized range finder with subspace iteration of Halko, Martinsson & Tropp
// (2011), Algorithm 4.4, each product orthonormalised. The products are in single precision:
// the basis need only span the dominant range (the rounding perturbs it by about 1e-7 of the
// largest singular value; the Rayleigh-Ritz values of the projection, in double, move less);
// the projection and the SVD after it are in double.
MatD range_basis(const CentredData& d, Eigen::Index l, const PcaSettings& s) {
  auto orthonormal_f = [](const Eigen::MatrixXf& v) {
    return orthonormal_columns(v.cast<double>()).cast<float>().eval();
  };
  Eigen::MatrixXf q = orthonormal_f(
      times(d, gaussian_matrix(Eigen::Index(d.cols()), l, s.seed).cast<float>().eval()));
  for (int i = 0; i < s.power_iterations; ++i)
    q = orthonormal_f(times(d, orthonormal_f(transpose_times(d, q))));
  return q.cast<double>();
}

// The top c right singular vectors by a randomized SVD (Halko et al. 2011, Algorithm 5.1): the
// exact SVD of the small B = Qᵀ Xc, Q from range_basis; |Xc|² in the same pass.
MatD randomized_directions(const CentredData& d, std::size_t c, const PcaSettings& s, Pca& p) {
  const Eigen::Index l =
      Eigen::Index(std::min({c + std::max<std::size_t>(10, c / 2), d.rows(), d.cols()}));
  const MatD b = transpose_times(d, range_basis(d, l, s), &p.total_energy).transpose();
  const Eigenpairs e = descending_eigenpairs(serial_product(b, b.transpose()));  // B Bᵀ, l x l
  p.singular_values.assign(e.values.begin(), e.values.end());
  p.randomized = true;
  return orthonormal_columns(serial_product(b.transpose(), e.vectors.leftCols(Eigen::Index(c))));
}

bool use_randomized(std::size_t rows, std::size_t cols, std::size_t c, const PcaSettings& s) {
  const std::size_t side = std::min(rows, cols);
  return side > s.randomized_above && 4 * (c + std::max<std::size_t>(10, c / 2)) < side;
}

}  // namespace

Pca principal_components(std::span<const float> x, std::size_t rows, std::size_t cols,
                         std::size_t components, const PcaSettings& s) {
  assert(x.size() == rows * cols && rows > 0 && components >= 1 && components <= cols);
  const CentredData d(x, rows, cols, s.centre);
  Pca p;
  p.rows = rows;
  p.cols = cols;
  p.components = components;
  const MatD v = use_randomized(rows, cols, components, s)
                     ? randomized_directions(d, components, s, p)
                     : gram_directions(d, components, s, p);
  for (double& sv : p.singular_values) sv = std::sqrt(sv);
  const MatD w = times(d, v);  // in double
  if (p.randomized) {
    p.discarded_energy = std::max(0.0, p.total_energy - w.squaredNorm());
  } else {
    for (std::size_t i = components; i < p.singular_values.size(); ++i)
      p.discarded_energy += p.singular_values[i] * p.singular_values[i];
  }
  p.mean.assign(d.mean().begin(), d.mean().end());
  p.directions.resize(components * cols);
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      p.directions.data(), Eigen::Index(components), Eigen::Index(cols)) = v.transpose();
  p.coordinates.resize(rows * components);
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      p.coordinates.data(), Eigen::Index(rows), Eigen::Index(components)) = w;
  return p;
}

std::vector<double> reconstruct(const Pca& p) {
  const Eigen::Index n = Eigen::Index(p.rows), d = Eigen::Index(p.cols),
                     c = Eigen::Index(p.components);
  std::vector<double> out(p.rows * p.cols);
  Eigen::Map<RowMatD> r(out.data(), n, d);
  r.noalias() = Eigen::Map<const RowMatD>(p.coordinates.data(), n, c) *
                Eigen::Map<const RowMatD>(p.directions.data(), c, d);
  r.rowwise() += Eigen::Map<const Eigen::RowVectorXd>(p.mean.data(), d);
  return out;
}

std::vector<double> fit_coordinates(std::span<const float> x, std::size_t rows, std::size_t cols,
                                    std::span<const float> mean, std::span<const float> basis,
                                    std::size_t c) {
  assert(x.size() == rows * cols && mean.size() == cols && basis.size() == c * cols);
  const MatD bt = Eigen::Map<const RowMatF>(basis.data(), Eigen::Index(c), Eigen::Index(cols))
                      .cast<double>()
                      .transpose();  // cols x c
  // The normal equations' matrix BBᵀ, pseudo-inverted once (rank-deficient bases too).
  const MatD solve =
      serial_product(bt.transpose(), bt).completeOrthogonalDecomposition().pseudoInverse();
  const Eigen::RowVectorXd m =
      Eigen::Map<const Eigen::RowVectorXf>(mean.data(), Eigen::Index(cols)).cast<double>();
  const Eigen::Map<const RowMatF> xs(x.data(), Eigen::Index(rows), Eigen::Index(cols));
  std::vector<double> out(rows * c);
  Eigen::Map<RowMatD> w(out.data(), Eigen::Index(rows), Eigen::Index(c));
  // Blocks of rows over OpenMP's threads, each writing its own rows (as `times`).
  const std::size_t step = std::max<std::size_t>(1, kBlockValues / std::max<std::size_t>(1, cols));
  const std::ptrdiff_t blocks = std::ptrdiff_t((rows + step - 1) / step);
#pragma omp parallel
  {
    RowMatD b(Eigen::Index(std::min(step, rows)), Eigen::Index(cols));
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t k = 0; k < blocks; ++k) {
      const std::size_t r0 = std::size_t(k) * step;
      const Eigen::Index n = Eigen::Index(std::min(step, rows - r0));
      b.topRows(n) = xs.middleRows(Eigen::Index(r0), n).cast<double>().rowwise() - m;
      w.middleRows(Eigen::Index(r0), n).noalias() = (b.topRows(n) * bt) * solve.transpose();
    }
  }
  return out;
}

}  // namespace btfgmm::detail
