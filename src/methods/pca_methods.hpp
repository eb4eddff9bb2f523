// What the three PCA methods (pca-btf, pca-rf, lpca) share: their settings' checks, the
// ladder of sizes, the stored factors of a payload, and a decode of measured pairs by matrix
// products.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/methods/representation.hpp"
#include "methods/factors.hpp"
#include "model/byte_io.hpp"

namespace btfgmm::detail {

// s.components, or `fallback` (clamped to `max`) when 0; Error(kArgument) outside 1..max:
// "`components` 900: pca-btf takes 1..255 for <what>" (what: "this tile of 256 images").
std::size_t components_setting(const FitOptions& s, std::string_view method,
                               std::size_t fallback, std::size_t max, const std::string& what);
// Error(kArgument) for --clusters given to a method that has none.
void refuse_clusters(const FitOptions& s, std::string_view method);
// Error(kArgument) once s.stop is set; reports progress where s.progress is set.
void check_stop(const FitOptions& s, std::string_view method);
void report(const FitOptions& s, double fraction, std::string_view stage);

// OpenMP's thread count set to `threads` (when > 0) for the scope's lifetime.
class ThreadScope {
 public:
  explicit ThreadScope(int threads);
  ~ThreadScope();
  ThreadScope(const ThreadScope&) = delete;
  ThreadScope& operator=(const ThreadScope&) = delete;

 private:
  int before_ = 0;
};

// Of candidate models ordered by size (their Table 2 ratios decreasing), the indices of those
// nearest (in log ratio) to ten ratios from 1:500 to 1:5 (about 1.5 to 2 times apart), smallest
// model first, each once.
std::vector<std::size_t> ladder_choice(std::span<const double> ratios);

std::vector<float> to_floats(std::span<const double> v);
// rows x cols -> cols x rows (row-major both).
std::vector<float> transposed(std::span<const float> v, std::size_t rows, std::size_t cols);

// The factors' encoding (a u8) and, for each block of factors, put_factors / get_factors with
// the block's own encoding checked against the model's, so that a model read back writes the
// same bytes.
FactorEncoding get_encoding(ByteReader& r);
std::vector<float> get_factors_as(ByteReader& r, std::span<const std::uint8_t> payload,
                                  std::size_t rows, std::size_t cols, FactorEncoding e,
                                  const char* field, FactorLayout layout = {});
// Before sizes from the file are multiplied: every value stored in a fixed-size encoding
// takes at least a byte, so more `values` than bytes left fail ("<what> do not fit the
// file"); the compact block bounds its own sizes (methods/compact_factors.hpp).
void expect_bytes_for(ByteReader& r, double values, FactorEncoding e, const std::string& what);

// r.fail() unless the payload is used up; the method's flags must be 0.
void expect_end(ByteReader& r);
void expect_no_flags(ByteReader& r, std::uint32_t flags);

// The index of every direction of `asked` in `measured` (DirectionSet::find), or nothing if one
// is not measured.
std::optional<std::vector<std::size_t>> measured_indices(const DirectionSet& measured,
                                                         const DirectionSet& asked);

// The reconstruction of every PCA method: out = mean + Σ_k w_k e_k over n values, for k < c,
// with e_k at e + k * e_stride and w_k at w[k * w_stride] (Koudelka et al. 2003, Sattler et
// al. 2003, Müller et al. 2003: the mean plus the weighted components).
void mean_plus_components(const float* mean, const float* e, std::size_t e_stride, const float* w,
                          std::size_t w_stride, std::size_t c, std::size_t n, float* out);

// out (rows x cols, row-major, rows `out_stride` floats apart) = w (rows x k) x basis (k x
// cols) + mean (a row of cols), in float: a matrix product (Eigen's).
void affine_product(const float* w, const float* basis, const float* mean, std::size_t rows,
                    std::size_t k, std::size_t cols, float* out, std::size_t out_stride);

}  // namespace btfgmm::detail
