// The compact encoding of the mixture (docs/FORMAT.md, "The compact encoding"): each
// parameter quantised with a stated step, the integer codes zigzagged, split into byte
// planes per column and compressed with zstd (model/coded_columns.hpp).
#include "model/compact.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "model/coded_columns.hpp"
#include "model/mixture_internal.hpp"

namespace btfgmm::detail {

// Version 5: the planes G, R - G and B - G of the codes (channel-major), each code less its
// planar prediction.
std::vector<std::int64_t> predicted_colour_planes(std::vector<std::int64_t> q, std::size_t nv) {
  const std::size_t n = q.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    std::swap(q[i], q[n + i]);                          // G first
    q[n + i] = wrapping_minus(q[n + i], q[i]);          // R - G
    q[2 * n + i] = wrapping_minus(q[2 * n + i], q[i]);  // B - G
  }
  std::vector<std::int64_t> r(q.size());
  for (std::size_t c = 0; c < 3; ++c) {
    const std::span<const std::int64_t> plane(q.data() + c * n, n);
    for (std::size_t i = 0; i < n; ++i)
      r[c * n + i] = wrapping_minus(plane[i], planar_prediction(plane, i, nv));
  }
  return r;
}

std::vector<std::int64_t> unpredicted_colour_planes(std::vector<std::int64_t> r, std::size_t nv) {
  const std::size_t n = r.size() / 3;
  for (std::size_t c = 0; c < 3; ++c) {
    const std::span<std::int64_t> plane(r.data() + c * n, n);
    for (std::size_t i = 0; i < n; ++i)
      plane[i] = wrapping_plus(plane[i], planar_prediction(plane, i, nv));
  }
  for (std::size_t i = 0; i < n; ++i) {
    r[n + i] = wrapping_plus(r[n + i], r[i]);
    r[2 * n + i] = wrapping_plus(r[2 * n + i], r[i]);
    std::swap(r[i], r[n + i]);
  }
  return r;
}

namespace {

// The columns of the mixture: ln w, ln sigma x 9, the six input means, the three colour means.
constexpr int kComponentColumns = 1 + kVariables + kVariables;

using Column = CodeColumn;

std::int64_t code_of(double v, double step) {
  return std::llround(v / step);
}

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

std::int64_t plus(std::int64_t a, std::int64_t b) {
  return wrapping_plus(a, b);
}

// Version 4's codes: each less the one before it along the views, the first view of a light
// less the first view of the light before. Undone in place.
void undo_view_deltas(std::span<std::int64_t> d, std::size_t nv) {
  for (std::size_t i = 0; i < d.size(); ++i)
    d[i] = plus(d[i], i % nv != 0 ? d[i - 1] : i >= nv ? d[i - nv] : 0);
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

void put_compact_components(ByteWriter& w, const BtfModel& m) {
  const CompactSteps& s = m.compact_steps;
  w.put<std::uint32_t>(std::uint32_t(m.mixture.size()));
  for (double step : {s.log_weight, s.log_sigma, s.input_mean, s.colour_mean, s.mean_brdf})
    w.put<double>(step);
  std::vector<std::uint8_t> raw;
  for (const Column& c : component_codes(m, s)) put_column(raw, c);
  for (const Column& c : mean_brdf_codes(m, brdf_step(m, s))) put_column(raw, c);
  const std::vector<std::uint8_t> packed = zstd_pack(raw);
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
  const std::vector<std::uint8_t> raw = zstd_unpack(r, packed, raw_size);
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
