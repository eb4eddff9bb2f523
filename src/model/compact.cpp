// The compact encoding of the mixture (docs/FORMAT.md, "The compact encoding"): each
// parameter quantised with a stated step, the integer codes zigzagged, split into byte
// planes per column and compressed with zstd.
#include "model/compact.hpp"

#include <fmt/format.h>
#include <zstd.h>

#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {
namespace {

constexpr int kZstdLevel = 19;
// The most a zstd frame can expand: 128 KiB from each block of at least 4 bytes (RFC 8878).
constexpr double kZstdMaxRatio = 131072.0 / 4.0;
// The columns of the mixture: ln w, ln sigma x 9, the six input means, the three colour means.
constexpr int kComponentColumns = 1 + kVariables + kVariables;

std::uint64_t zigzag(std::int64_t v) {
  return (std::uint64_t(v) << 1) ^ std::uint64_t(v >> 63);
}
std::int64_t unzigzag(std::uint64_t z) {
  return std::int64_t(z >> 1) ^ -std::int64_t(z & 1);
}

std::int64_t code_of(double v, double step) {
  return std::llround(v / step);
}

}  // namespace

// One column: u8 width k (bytes per code), then k byte planes of n bytes, the low byte first.
void put_column(std::vector<std::uint8_t>& out, const Column& c) {
  std::uint64_t top = 0;
  for (std::int64_t v : c) top |= zigzag(v);
  std::uint8_t k = 1;
  while (k < 8 && (top >> (8 * k)) != 0) ++k;
  out.push_back(k);
  for (int plane = 0; plane < k; ++plane)
    for (std::int64_t v : c) out.push_back(std::uint8_t(zigzag(v) >> (8 * plane)));
}

Column get_column(ByteReader& r, std::size_t n) {
  const auto k = r.get<std::uint8_t>("column width");
  if (k < 1 || k > 8) r.fail(fmt::format("a compact column of {} bytes a code", int(k)));
  if (std::size_t(k) * n > r.remaining()) r.fail("a compact column runs past its block");
  std::vector<std::uint64_t> z(n, 0);
  for (int plane = 0; plane < k; ++plane)
    for (std::size_t i = 0; i < n; ++i)
      z[i] |= std::uint64_t(r.get<std::uint8_t>("code")) << (8 * plane);
  Column c(n);
  for (std::size_t i = 0; i < n; ++i) c[i] = unzigzag(z[i]);
  return c;
}

namespace {

// The codes of the mixture, column by column (component order kept).
std::vector<Column> component_codes(const BtfModel& m, const CompactSteps& s) {
  const ProductMixture& mix = m.mixture;
  const Periods periods = variable_periods({double(m.width), double(m.height)});
  std::vector<Column> cols(kComponentColumns, Column(mix.size()));
  for (std::size_t k = 0; k < mix.size(); ++k) {
    cols[0][k] = code_of(std::log(mix.weight[k]), s.log_weight);
    for (int n = 0; n < kVariables; ++n) {
      const std::int64_t cs = code_of(0.5 * std::log(mix.var[k][n]), s.log_sigma);
      cols[1 + n][k] = cs;
      const double mu =
          periods[n] > 0.0 ? wrap_into_period(mix.mean[k][n], periods[n]) : mix.mean[k][n];
      const double step =
          n < kInputs ? std::exp(double(cs) * s.log_sigma) * s.input_mean : s.colour_mean;
      cols[1 + kVariables + n][k] = code_of(mu, step);
    }
  }
  return cols;
}

// The parameters the codes stand for (weights renormalised to sum 1).
ProductMixture components_of(const std::vector<Column>& cols, const CompactSteps& s) {
  const std::size_t count = cols[0].size();
  ProductMixture mix;
  mix.resize(count);
  double total = 0.0;
  for (std::size_t k = 0; k < count; ++k) {
    mix.weight[k] = std::exp(double(cols[0][k]) * s.log_weight);
    total += mix.weight[k];
    for (int n = 0; n < kVariables; ++n) {
      const double sigma = std::exp(double(cols[1 + n][k]) * s.log_sigma);
      mix.var[k][n] = sigma * sigma;
      const double step = n < kInputs ? sigma * s.input_mean : s.colour_mean;
      mix.mean[k][n] = double(cols[1 + kVariables + n][k]) * step;
    }
  }
  for (double& w : mix.weight) w /= total;
  return mix;
}

// The mean BRDF's integer codes, channel-major: c * n + l * nv + v.
std::vector<std::int64_t> mean_brdf_quanta(const BtfModel& m, double step) {
  const std::size_t n = m.lights.size() * m.views.size();
  std::vector<std::int64_t> q(3 * n);
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i)
      q[std::size_t(c) * n + i] = code_of(double(m.mean_brdf[i * 3 + std::size_t(c)]), step);
  return q;
}

std::vector<float> mean_brdf_values(const std::vector<std::int64_t>& q, double step) {
  const std::size_t n = q.size() / 3;
  std::vector<float> out(n * 3);
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i)
      out[i * 3 + std::size_t(c)] = float(double(q[std::size_t(c) * n + i]) * step);
  return out;
}

// The sums and differences of codes wrap modulo 2^64, so that a file's codes, however large,
// are undone exactly and with no overflow (a reader meets corrupted files).
std::int64_t plus(std::int64_t a, std::int64_t b) {
  return std::int64_t(std::uint64_t(a) + std::uint64_t(b));
}
std::int64_t minus(std::int64_t a, std::int64_t b) {
  return std::int64_t(std::uint64_t(a) - std::uint64_t(b));
}

// Version 4's codes: each less the one before it along the views, the first view of a light
// less the first view of the light before. Undone in place.
void undo_view_deltas(std::span<std::int64_t> d, std::size_t nv) {
  for (std::size_t i = 0; i < d.size(); ++i)
    d[i] = plus(d[i], i % nv != 0 ? d[i - 1] : i >= nv ? d[i - nv] : 0);
}

// The plane through the three neighbours on the light x view grid of one plane p (lossless
// JPEG's predictor 4, ITU-T T.81 Table H.1): a + b - c from the code before along the views
// (a), the one of the light before (b) and the one before both (c); at the grid's first row
// and column the neighbours missing are a (and a is b, or 0, at the first view), so the
// prediction there is a.
std::int64_t planar_prediction(std::span<const std::int64_t> p, std::size_t i, std::size_t nv) {
  const bool left = i % nv != 0, up = i >= nv;
  const std::int64_t a = left ? p[i - 1] : up ? p[i - nv] : 0;
  const std::int64_t b = up ? p[i - nv] : a;
  const std::int64_t c = left && up ? p[i - nv - 1] : a;
  return minus(plus(a, b), c);
}

// The mean BRDF's columns as version 5 writes them (one per plane).
std::vector<Column> mean_brdf_codes(const BtfModel& m, double step) {
  const std::vector<std::int64_t> r =
      predicted_colour_planes(mean_brdf_quanta(m, step), m.views.size());
  const std::size_t n = r.size() / 3;
  std::vector<Column> cols;
  for (std::size_t c = 0; c < 3; ++c)
    cols.emplace_back(r.begin() + std::ptrdiff_t(c * n), r.begin() + std::ptrdiff_t((c + 1) * n));
  return cols;
}

// The mean BRDF that the columns of either coding stand for.
std::vector<float> mean_brdf_of(const std::vector<Column>& cols, std::size_t nv, double step,
                                MeanBrdfCoding coding) {
  std::vector<std::int64_t> r;
  for (const Column& c : cols) r.insert(r.end(), c.begin(), c.end());
  if (coding == MeanBrdfCoding::kPredicted)
    return mean_brdf_values(unpredicted_colour_planes(r, nv), step);
  const std::size_t n = r.size() / 3;
  for (std::size_t c = 0; c < 3; ++c) undo_view_deltas(std::span(r).subspan(c * n, n), nv);
  return mean_brdf_values(r, step);
}

double brdf_step(const BtfModel& m, const CompactSteps& s) {
  return s.mean_brdf * m.scaling.unit[6];
}

void check_step(ByteReader& r, double step) {
  if (!(step > 0.0) || !std::isfinite(step))
    r.fail(fmt::format("a quantisation step {} is not positive", step));
}

}  // namespace

std::vector<std::int64_t> predicted_colour_planes(std::vector<std::int64_t> q, std::size_t nv) {
  const std::size_t n = q.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    std::swap(q[i], q[n + i]);                 // G first
    q[n + i] = minus(q[n + i], q[i]);          // R - G
    q[2 * n + i] = minus(q[2 * n + i], q[i]);  // B - G
  }
  std::vector<std::int64_t> r(q.size());
  for (std::size_t c = 0; c < 3; ++c) {
    const std::span<const std::int64_t> plane(q.data() + c * n, n);
    for (std::size_t i = 0; i < n; ++i)
      r[c * n + i] = minus(plane[i], planar_prediction(plane, i, nv));
  }
  return r;
}

std::vector<std::int64_t> unpredicted_colour_planes(std::vector<std::int64_t> r, std::size_t nv) {
  const std::size_t n = r.size() / 3;
  for (std::size_t c = 0; c < 3; ++c) {
    const std::span<std::int64_t> plane(r.data() + c * n, n);
    for (std::size_t i = 0; i < n; ++i) plane[i] = plus(plane[i], planar_prediction(plane, i, nv));
  }
  for (std::size_t i = 0; i < n; ++i) {
    r[n + i] = plus(r[n + i], r[i]);
    r[2 * n + i] = plus(r[2 * n + i], r[i]);
    std::swap(r[i], r[n + i]);
  }
  return r;
}

std::vector<std::uint8_t> compress_codes(const std::vector<std::uint8_t>& raw) {
  std::vector<std::uint8_t> packed(ZSTD_compressBound(raw.size()));
  const std::size_t n =
      ZSTD_compress(packed.data(), packed.size(), raw.data(), raw.size(), kZstdLevel);
  if (ZSTD_isError(n))
    throw Error(Error::Kind::kIo,
                fmt::format("zstd could not compress the model: {}", ZSTD_getErrorName(n)));
  packed.resize(n);
  return packed;
}

std::vector<std::uint8_t> decompress_codes(ByteReader& r, std::span<const std::uint8_t> packed,
                                           std::uint64_t raw_size) {
  if (ZSTD_getFrameContentSize(packed.data(), packed.size()) != raw_size)
    r.fail("the compressed codes do not hold the size the file states");
  // Before allocating for it: what the codes can hold at most.
  if (double(raw_size) > kZstdMaxRatio * double(packed.size()))
    r.fail(fmt::format("the compressed codes claim {} bytes, more than their {} bytes can hold",
                       raw_size, packed.size()));
  std::vector<std::uint8_t> raw(static_cast<std::size_t>(raw_size));
  const std::size_t got = ZSTD_decompress(raw.data(), raw.size(), packed.data(), packed.size());
  if (ZSTD_isError(got) || got != raw.size()) r.fail("the compressed codes are corrupted");
  return raw;
}

void put_compact_components(ByteWriter& w, const BtfModel& m) {
  const CompactSteps& s = m.compact_steps;
  w.put<std::uint32_t>(std::uint32_t(m.mixture.size()));
  for (double step : {s.log_weight, s.log_sigma, s.input_mean, s.colour_mean, s.mean_brdf})
    w.put<double>(step);
  std::vector<std::uint8_t> raw;
  for (const Column& c : component_codes(m, s)) put_column(raw, c);
  for (const Column& c : mean_brdf_codes(m, brdf_step(m, s))) put_column(raw, c);
  const std::vector<std::uint8_t> packed = compress_codes(raw);
  w.put<std::uint64_t>(std::uint64_t(raw.size()));
  w.bytes.insert(w.bytes.end(), packed.begin(), packed.end());
}

void get_compact_components(ByteReader& r, BtfModel& m, MeanBrdfCoding coding) {
  const auto count = r.get<std::uint32_t>("components");
  CompactSteps& s = m.compact_steps;
  for (double* step : {&s.log_weight, &s.log_sigma, &s.input_mean, &s.colour_mean, &s.mean_brdf}) {
    *step = r.get<double>("quantisation step");
    check_step(r, *step);
  }
  check_step(r, brdf_step(m, s));  // in the data's scale: the colour unit times s_b
  const auto raw_size = r.get<std::uint64_t>("coded size");
  const std::size_t directions = m.lights.size() * m.views.size();
  // Every column at most 8 bytes a code, plus its width byte.
  const double largest =
      double(kComponentColumns) * (1.0 + 8.0 * count) + 3.0 * (1.0 + 8.0 * double(directions));
  if (count == 0 || double(raw_size) > largest)
    r.fail(fmt::format("{} components and {} coded bytes do not go together", count, raw_size));
  std::vector<std::uint8_t> packed(r.remaining());
  for (auto& b : packed) b = r.get<std::uint8_t>("compressed codes");
  const std::vector<std::uint8_t> raw = decompress_codes(r, packed, raw_size);
  ByteReader cr(raw, "model file", "(its compressed codes)", "fit the model again");
  std::vector<Column> comp, brdf;
  for (int c = 0; c < kComponentColumns; ++c) comp.push_back(get_column(cr, count));
  for (int c = 0; c < 3; ++c) brdf.push_back(get_column(cr, directions));
  if (cr.remaining() != 0) r.fail("the compressed codes hold bytes left over");
  m.mixture = components_of(comp, s);
  m.mean_brdf = mean_brdf_of(brdf, m.views.size(), brdf_step(m, s), coding);
  for (std::size_t k = 0; k < count; ++k) {
    bool ok = m.mixture.weight[k] > 0.0 && std::isfinite(m.mixture.weight[k]);
    for (int n = 0; n < kVariables; ++n)
      ok = ok && std::isfinite(m.mixture.mean[k][n]) && m.mixture.var[k][n] > 0.0 &&
           std::isfinite(m.mixture.var[k][n]);
    if (!ok) r.fail(fmt::format("component {} has a non-finite or non-positive parameter", k));
  }
  for (float v : m.mean_brdf)
    if (!std::isfinite(v)) r.fail("the mean BRDF holds a non-finite value");
}

BtfModel round_to_compact(const BtfModel& m) {
  const CompactSteps& s = m.compact_steps;
  BtfModel out = m;
  out.mixture = components_of(component_codes(m, s), s);
  out.mean_brdf = mean_brdf_values(mean_brdf_quanta(m, brdf_step(m, s)), brdf_step(m, s));
  return out;
}

}  // namespace btfgmm::detail
