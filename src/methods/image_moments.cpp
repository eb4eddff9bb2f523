// Each image's per-channel mean and deviation (image_moments.hpp): measured, stored at a
// byte a value, matched.
#include "methods/image_moments.hpp"

#include <fmt/format.h>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "model/coded_columns.hpp"
#include "model/compact.hpp"

namespace btfgmm::detail {
namespace {

constexpr std::size_t kPlanes = 6;

// A step that codes 0 .. `largest` in 255 steps (a positive one where all are 0).
double step_for(const std::vector<float>& v) {
  const float largest = v.empty() ? 0.0f : *std::max_element(v.begin(), v.end());
  return largest > 0.0f ? double(largest) / 255.0 : 1.0;
}

std::uint8_t code_of(float v, double step) {
  return std::uint8_t(std::clamp(std::lround(double(v) / step), 0L, 255L));
}

void round_to_codes(std::vector<float>& v, double step) {
  for (float& x : v) x = float(code_of(x, step) * step);
}

}  // namespace

void measure_moments(const float* rgb, std::size_t pixels, float* mean, float* deviation) {
  for (std::size_t c = 0; c < 3; ++c) {
    double s = 0, q = 0;
    for (std::size_t p = 0; p < pixels; ++p) s += rgb[p * 3 + c];
    const double m = s / double(pixels);
    for (std::size_t p = 0; p < pixels; ++p) q += (rgb[p * 3 + c] - m) * (rgb[p * 3 + c] - m);
    mean[c] = float(m), deviation[c] = float(std::sqrt(q / double(pixels)));
  }
}

namespace {

double get_step(ByteReader& r, const char* field) {
  const double step = r.get<float>(field);
  if (!(std::isfinite(step) && step > 0.0))
    r.fail(fmt::format("{} {} is not positive", field, step));
  return step;
}

}  // namespace

ImageMoments measure_image_moments(const Btf& tile) {
  ImageMoments m;
  const std::size_t n = tile.image_count(), pixels = tile.image_floats() / 3;
  m.mean.resize(n * 3), m.deviation.resize(n * 3);
  for (std::size_t i = 0; i < n; ++i)
    measure_moments(tile.data().data() + i * tile.image_floats(), pixels, &m.mean[i * 3],
                    &m.deviation[i * 3]);
  // As the file's f32 holds them.
  const bool levels = tile.format() != SampleFormat::kHdr;
  m.mean_step = levels ? kMeanStep : double(float(step_for(m.mean)));
  m.deviation_step = levels ? kDeviationStep : double(float(step_for(m.deviation)));
  round_to_codes(m.mean, m.mean_step);
  round_to_codes(m.deviation, m.deviation_step);
  return m;
}

namespace {

// The codes of one kind of moment (the means or the deviations), channel-major: c * n + i.
std::vector<std::int64_t> codes_of(const std::vector<float>& v, double step) {
  const std::size_t n = v.size() / 3;
  std::vector<std::int64_t> q(v.size());
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i) q[c * n + i] = code_of(v[i * 3 + c], step);
  return q;
}

// The values of channel-major codes, each checked to be a byte's.
std::vector<float> values_of(ByteReader& r, const std::vector<std::int64_t>& q, double step,
                             const char* what) {
  const std::size_t n = q.size() / 3;
  std::vector<float> v(q.size());
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n; ++i) {
      const std::int64_t code = q[c * n + i];
      if (code < 0 || code > 255)
        r.fail(fmt::format("an image {} code {} is not 0..255", what, code));
      v[i * 3 + c] = float(double(code) * step);
    }
  return v;
}

// Version 6's block after its steps.
void get_delta_codes(ByteReader& r, ImageMoments& m, std::size_t images) {
  const std::size_t size = r.get<std::uint32_t>("image moments size");
  if (size > r.remaining())
    r.fail(fmt::format("image moments claim {} bytes, {} are left", size, r.remaining()));
  std::vector<std::uint8_t> packed(size);
  for (std::uint8_t& b : packed) b = r.get<std::uint8_t>("image moments");
  std::vector<std::uint8_t> raw(kPlanes * images);
  if (ZSTD_getFrameContentSize(packed.data(), packed.size()) != raw.size())
    r.fail(fmt::format("image moments do not hold {} codes", raw.size()));
  const std::size_t got = ZSTD_decompress(raw.data(), raw.size(), packed.data(), packed.size());
  if (ZSTD_isError(got) || got != raw.size()) r.fail("the image moments are corrupted");
  m.mean.resize(images * 3), m.deviation.resize(images * 3);
  for (std::size_t plane = 0; plane < kPlanes; ++plane) {
    std::vector<float>& v = plane < 3 ? m.mean : m.deviation;
    const double step = plane < 3 ? m.mean_step : m.deviation_step;
    std::uint8_t code = 0;
    for (std::size_t i = 0; i < images; ++i) {
      code = std::uint8_t(code + raw[plane * images + i]);
      v[i * 3 + plane % 3] = float(code * step);
    }
  }
}

// Version 7's block after its steps: the predicted planes of the means and the deviations.
void get_predicted_codes(ByteReader& r, ImageMoments& m, std::size_t images, std::size_t views) {
  const auto raw_size = r.get<std::uint64_t>("image moments coded size");
  const std::size_t size = r.get<std::uint32_t>("image moments size");
  // Every column at most 8 bytes a code, plus its width byte.
  if (double(raw_size) > double(kPlanes) * (1.0 + 8.0 * double(images)))
    r.fail(fmt::format("image moments claim {} coded bytes for {} images", raw_size, images));
  if (size > r.remaining())
    r.fail(fmt::format("image moments claim {} bytes, {} are left", size, r.remaining()));
  std::vector<std::uint8_t> packed(size);
  for (std::uint8_t& b : packed) b = r.get<std::uint8_t>("image moments");
  const std::vector<std::uint8_t> raw = zstd_unpack(r, packed, raw_size);
  ByteReader cr(raw, "model file", "(its image moments)", "fit the model again");
  std::vector<std::int64_t> planes[2];
  for (std::size_t plane = 0; plane < kPlanes; ++plane) {
    const CodeColumn c = get_column(cr, images);
    planes[plane / 3].insert(planes[plane / 3].end(), c.begin(), c.end());
  }
  if (cr.remaining() != 0) r.fail("the image moments' codes hold bytes left over");
  m.mean = values_of(r, unpredicted_colour_planes(planes[0], views), m.mean_step, "mean");
  m.deviation =
      values_of(r, unpredicted_colour_planes(planes[1], views), m.deviation_step, "deviation");
}

}  // namespace

void put_image_moments(ByteWriter& w, const ImageMoments& m, std::size_t views) {
  std::vector<std::uint8_t> raw;
  for (const auto& [v, step] :
       {std::pair(&m.mean, m.mean_step), {&m.deviation, m.deviation_step}}) {
    const std::vector<std::int64_t> r = predicted_colour_planes(codes_of(*v, step), views);
    const std::size_t n = r.size() / 3;
    for (std::size_t c = 0; c < 3; ++c)
      put_column(raw, CodeColumn(r.begin() + std::ptrdiff_t(c * n),
                                 r.begin() + std::ptrdiff_t((c + 1) * n)));
  }
  const std::vector<std::uint8_t> packed = zstd_pack(raw);
  w.put<float>(float(m.mean_step));
  w.put<float>(float(m.deviation_step));
  w.put<std::uint64_t>(std::uint64_t(raw.size()));
  w.put<std::uint32_t>(std::uint32_t(packed.size()));
  w.bytes.insert(w.bytes.end(), packed.begin(), packed.end());
}

ImageMoments get_image_moments(ByteReader& r, std::size_t images, std::size_t views,
                               MomentsCoding coding) {
  ImageMoments m;
  m.mean_step = get_step(r, "image mean step");
  m.deviation_step = get_step(r, "image deviation step");
  if (coding == MomentsCoding::kDeltas)
    get_delta_codes(r, m, images);
  else
    get_predicted_codes(r, m, images, views);
  return m;
}

float within_levels(float v) {
  constexpr float lo = 1.0f + kKnee, hi = 254.0f - kKnee;
  if (v > hi) return hi + kKnee * std::tanh((v - hi) / kKnee);
  if (v < lo) return lo - kKnee * std::tanh((lo - v) / kKnee);
  return v;
}

void match_moments(float* rgb, std::size_t pixels, const float* mean, const float* deviation) {
  float have_mean[3], have_deviation[3];
  measure_moments(rgb, pixels, have_mean, have_deviation);
  for (std::size_t c = 0; c < 3; ++c) {
    const float scale = have_deviation[c] > 0.0f ? deviation[c] / have_deviation[c] : 0.0f;
    for (std::size_t p = 0; p < pixels; ++p)
      rgb[p * 3 + c] = mean[c] + (rgb[p * 3 + c] - have_mean[c]) * scale;
  }
}

namespace {

// The marginal's codes: z on 255 steps between each channel's ends.
std::vector<float> coded_marginal(const std::vector<float>& z) {
  std::vector<float> out(z.size());
  for (std::size_t c = 0; c < 3; ++c) {
    const float* q = &z[c * kQuantiles];
    const float lo = q[0], hi = q[kQuantiles - 1];
    const double step = hi > lo ? double(hi - lo) / 255.0 : 1.0;
    for (std::size_t k = 0; k < kQuantiles; ++k)
      out[c * kQuantiles + k] = float(lo + code_of(q[k] - lo, step) * step);
  }
  return out;
}

}  // namespace

std::vector<float> measure_marginal(const float* rgb, std::size_t pixels) {
  float mean[3], deviation[3];
  measure_moments(rgb, pixels, mean, deviation);
  std::vector<float> z(3 * kQuantiles), v(pixels);
  for (std::size_t c = 0; c < 3; ++c) {
    for (std::size_t p = 0; p < pixels; ++p)
      v[p] = deviation[c] > 0.0f ? (rgb[p * 3 + c] - mean[c]) / deviation[c] : 0.0f;
    std::sort(v.begin(), v.end());
    for (std::size_t k = 0; k < kQuantiles; ++k) {
      const double at = double(k) * double(pixels - 1) / double(kQuantiles - 1);
      const std::size_t i = std::size_t(at);
      const double f = at - double(i);
      z[c * kQuantiles + k] = float(v[i] * (1 - f) + (i + 1 < pixels ? v[i + 1] : v[i]) * f);
    }
  }
  return coded_marginal(z);
}

void put_marginal(ByteWriter& w, const std::vector<float>& z) {
  for (std::size_t c = 0; c < 3; ++c) {
    const float lo = z[c * kQuantiles], hi = z[c * kQuantiles + kQuantiles - 1];
    const double step = hi > lo ? double(hi - lo) / 255.0 : 1.0;
    w.put<float>(lo), w.put<float>(hi);
    for (std::size_t k = 0; k < kQuantiles; ++k)
      w.put<std::uint8_t>(code_of(z[c * kQuantiles + k] - lo, step));
  }
}

std::vector<float> get_marginal(ByteReader& r) {
  std::vector<float> z(3 * kQuantiles);
  for (std::size_t c = 0; c < 3; ++c) {
    const float lo = r.get<float>("marginal lowest"), hi = r.get<float>("marginal highest");
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo <= hi))
      r.fail(fmt::format("marginal range {} to {} is not one", lo, hi));
    const double step = hi > lo ? double(hi - lo) / 255.0 : 1.0;
    std::uint8_t before = 0;
    for (std::size_t k = 0; k < kQuantiles; ++k) {
      const std::uint8_t code = r.get<std::uint8_t>("marginal quantiles");
      if (code < before) r.fail("marginal quantiles decrease");
      z[c * kQuantiles + k] = float(lo + code * step);
      before = code;
    }
  }
  return z;
}

void match_marginal(float* rgb, std::size_t pixels, const std::vector<float>& z) {
  if (pixels < 2) return;
  float mean[3], deviation[3];
  measure_moments(rgb, pixels, mean, deviation);
  std::vector<std::size_t> order(pixels);
  for (std::size_t c = 0; c < 3; ++c) {
    for (std::size_t p = 0; p < pixels; ++p) order[p] = p;
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return rgb[a * 3 + c] < rgb[b * 3 + c]; });
    const float* q = &z[c * kQuantiles];
    for (std::size_t rank = 0; rank < pixels; ++rank) {
      const double at = double(rank) * double(kQuantiles - 1) / double(pixels - 1);
      const std::size_t k = std::min(std::size_t(at), kQuantiles - 2);
      const double f = at - double(k), value = q[k] * (1 - f) + q[k + 1] * f;
      rgb[order[rank] * 3 + c] = float(mean[c] + deviation[c] * value);
    }
  }
}

}  // namespace btfgmm::detail
