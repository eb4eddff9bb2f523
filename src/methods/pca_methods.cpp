// The PCA methods' shared settings checks, ladder, payload fields and products.
#include "methods/pca_methods.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"
#include "core/eigen_dense.hpp"
#include "methods/factors.hpp"

namespace btfgmm::detail {

std::size_t components_setting(const FitOptions& s, std::string_view method,
                               std::size_t fallback, std::size_t max, const std::string& what) {
  if (max < 1)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("{} needs more data than {}: it cannot take one component", method, what));
  if (s.components == 0) return std::min(fallback, max);
  if (s.components > max)
    throw Error(Error::Kind::kArgument, fmt::format("`components` {}: {} takes 1..{} for {}",
                                                    s.components, method, max, what));
  return s.components;
}

void refuse_clusters(const FitOptions& s, std::string_view method) {
  if (s.clusters != 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("`clusters` {}: {} has no clusters (`clusters` applies to lpca); "
                            "its size is `components`",
                            s.clusters, method));
}

void check_stop(const FitOptions& s, std::string_view method) {
  if (s.stop && s.stop->load())
    throw Error(Error::Kind::kArgument, fmt::format("the {} fit was stopped", method));
}

void report(const FitOptions& s, double fraction, std::string_view stage) {
  if (s.progress) s.progress(std::clamp(fraction, 0.0, 1.0), stage);
}

ThreadScope::ThreadScope(int threads) : before_(omp_get_max_threads()) {
  if (threads > 0) omp_set_num_threads(threads);
}

ThreadScope::~ThreadScope() {
  omp_set_num_threads(before_);
}

std::vector<std::size_t> ladder_choice(std::span<const double> ratios) {
  std::vector<std::size_t> out;
  for (double target : {500.0, 300.0, 150.0, 80.0, 50.0, 30.0, 15.0, 10.0, 7.0, 5.0}) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < ratios.size(); ++i)
      if (std::abs(std::log(ratios[i] / target)) < std::abs(std::log(ratios[best] / target)))
        best = i;
    if (!ratios.empty() && std::find(out.begin(), out.end(), best) == out.end())
      out.push_back(best);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<float> to_floats(std::span<const double> v) {
  std::vector<float> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out[i] = float(v[i]);
  return out;
}

std::vector<float> transposed(std::span<const float> v, std::size_t rows, std::size_t cols) {
  std::vector<float> out(v.size());
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) out[j * rows + i] = v[i * cols + j];
  return out;
}

FactorEncoding get_encoding(ByteReader& r) {
  const auto e = r.get<std::uint8_t>("factor encoding");
  if (e > 3) r.fail(fmt::format("unknown factor encoding {}", e));
  return FactorEncoding(e);
}

std::vector<float> get_factors_as(ByteReader& r, std::span<const std::uint8_t> payload,
                                  std::size_t rows, std::size_t cols, FactorEncoding e,
                                  const char* field, FactorLayout layout) {
  if (r.remaining() > 0 && payload[r.pos()] != std::uint8_t(e))
    r.fail(fmt::format("{} are stored as encoding {}, the model's factors as {} ({})", field,
                       payload[r.pos()], std::uint8_t(e), to_string(e)));
  return get_factors(r, rows, cols, field, layout);
}

void expect_bytes_for(ByteReader& r, double values, FactorEncoding e, const std::string& what) {
  if (e != FactorEncoding::kCompact && values > double(r.remaining()))
    r.fail(fmt::format("{} do not fit the file", what));
}

void expect_end(ByteReader& r) {
  if (r.remaining() != 0)
    r.fail(fmt::format("{} bytes follow the model's last field", r.remaining()));
}

void expect_no_flags(ByteReader& r, std::uint32_t flags) {
  if (flags != 0) r.fail(fmt::format("flags {:#x} where this method sets none", flags));
}

std::optional<std::vector<std::size_t>> measured_indices(const DirectionSet& measured,
                                                         const DirectionSet& asked) {
  std::vector<std::size_t> out;
  for (const Direction& d : asked) {
    const std::optional<std::size_t> i = measured.find(d);
    if (!i) return std::nullopt;
    out.push_back(*i);
  }
  return out;
}

void mean_plus_components(const float* mean, const float* e, std::size_t e_stride, const float* w,
                          std::size_t w_stride, std::size_t c, std::size_t n, float* out) {
  std::copy_n(mean, n, out);
  for (std::size_t k = 0; k < c; ++k) {
    const float wk = w[k * w_stride];
    const float* ek = e + k * e_stride;
#pragma omp simd
    for (std::size_t j = 0; j < n; ++j) out[j] += wk * ek[j];
  }
}

void affine_product(const float* w, const float* basis, const float* mean, std::size_t rows,
                    std::size_t k, std::size_t cols, float* out, std::size_t out_stride) {
  using RowMatF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Map<RowMatF, 0, Eigen::OuterStride<>> o(out, Eigen::Index(rows), Eigen::Index(cols),
                                                 Eigen::OuterStride<>(Eigen::Index(out_stride)));
  o.noalias() = Eigen::Map<const RowMatF>(w, Eigen::Index(rows), Eigen::Index(k)) *
                Eigen::Map<const RowMatF>(basis, Eigen::Index(k), Eigen::Index(cols));
  o.rowwise() += Eigen::Map<const Eigen::RowVectorXf>(mean, Eigen::Index(cols));
}

}  // namespace btfgmm::detail
