// Any pixel, light and view from the images of measured (light, view) pairs: bilinear in
// space, barycentric over the measured directions (measured_images.hpp).
#include "btfgmm/methods/measured_images.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "model/conditional.hpp"

namespace btfgmm {

MeasuredImages::MeasuredImages(ModelFrame frame)
    : frame_(std::move(frame)),
      lights_(std::make_unique<DirectionInterpolator>(frame_.lights)),
      views_(std::make_unique<DirectionInterpolator>(frame_.views)) {}

MeasuredImages::~MeasuredImages() = default;

void MeasuredImages::measured_image(std::size_t light, std::size_t view, float* rgb) const {
  for (int y = 0; y < frame_.height; ++y)
    for (int x = 0; x < frame_.width; ++x)
      measured_pixel(light, view, x, y,
                     rgb + (std::size_t(y) * std::size_t(frame_.width) + std::size_t(x)) * 3);
}

void MeasuredImages::light_pixels(const Direction& light, std::span<const ViewPixel> samples,
                                  float* rgb) const {
  const auto w = lights_->weights(light);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ViewPixel& s = samples[i];
    double sum[3] = {0, 0, 0};
    for (std::size_t a = 0; a < 3; ++a) {
      if (w.weight[a] == 0.0) continue;
      float v[3];
      measured_pixel(w.index[a], s.view, s.x, s.y, v);
      for (int c = 0; c < 3; ++c) sum[c] += w.weight[a] * double(v[c]);
    }
    for (int c = 0; c < 3; ++c) rgb[i * 3 + std::size_t(c)] = float(sum[c]);
  }
}

void MeasuredImages::light_image(const Direction& light, std::size_t view, float* rgb) const {
  const auto w = lights_->weights(light);
  const std::size_t n = frame_.pixels() * 3;
  std::vector<double> sum(n, 0.0);
  std::vector<float> image(n);
  for (std::size_t a = 0; a < 3; ++a) {
    if (w.weight[a] == 0.0) continue;
    measured_image(w.index[a], view, image.data());
    for (std::size_t i = 0; i < n; ++i) sum[i] += w.weight[a] * double(image[i]);
  }
  for (std::size_t i = 0; i < n; ++i) rgb[i] = float(sum[i]);
}

namespace {

// The four pixels around a tile position and their bilinear weights (pixel centres at whole
// coordinates; the tile wraps), as render/data_evaluator.cpp weighs the data.
struct Bilinear {
  int x[2] = {0, 0}, y[2] = {0, 0};
  double w[2][2] = {{0, 0}, {0, 0}};  // [dy][dx]
};

Bilinear bilinear(double qx, double qy, int width, int height) {
  const double x = detail::tile_coordinate(qx, width), y = detail::tile_coordinate(qy, height);
  Bilinear b;
  b.x[0] = int(std::floor(x)) % width;
  b.y[0] = int(std::floor(y)) % height;
  b.x[1] = (b.x[0] + 1) % width;
  b.y[1] = (b.y[0] + 1) % height;
  const double fx = x - std::floor(x), fy = y - std::floor(y);
  b.w[0][0] = (1 - fx) * (1 - fy);
  b.w[0][1] = fx * (1 - fy);
  b.w[1][0] = (1 - fx) * fy;
  b.w[1][1] = fx * fy;
  return b;
}

}  // namespace

// Up to 3 views x 4 pixels, the light's values of all of them from one light_pixels call.
void MeasuredImages::predict_one(const Query& q, float* rgb) const {
  const auto wv = views_->weights(q.view);
  const Bilinear b = bilinear(q.x, q.y, frame_.width, frame_.height);
  std::array<ViewPixel, 12> samples;
  std::array<double, 12> weights;
  std::size_t n = 0;
  for (std::size_t a = 0; a < 3; ++a)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const double w = wv.weight[a] * b.w[dy][dx];
        if (w == 0.0) continue;
        samples[n] = {wv.index[a], b.x[dx], b.y[dy]};
        weights[n++] = w;
      }
  float values[12 * 3];
  light_pixels(q.light, std::span(samples).first(n), values);
  double sum[3] = {0, 0, 0};
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t c = 0; c < 3; ++c) sum[c] += weights[k] * double(values[k * 3 + c]);
  for (std::size_t c = 0; c < 3; ++c) rgb[c] = float(sum[c]);
}

void MeasuredImages::predict(std::span<const Query> queries, std::span<float> rgb) const {
  if (rgb.size() < queries.size() * 3)
    throw Error(Error::Kind::kArgument, "predict: the output holds fewer than 3 floats a query");
  for (const Query& q : queries) {
    detail::check_direction(q.light, "light");
    detail::check_direction(q.view, "view");
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw Error(Error::Kind::kArgument,
                  fmt::format("query position ({}, {}) is not finite", q.x, q.y));
  }
  const std::ptrdiff_t n = std::ptrdiff_t(queries.size());
#pragma omp parallel for schedule(dynamic, 64)
  for (std::ptrdiff_t i = 0; i < n; ++i)
    predict_one(queries[std::size_t(i)], rgb.data() + std::size_t(i) * 3);
}

Btf MeasuredImages::decode(const DirectionSet& lights, const DirectionSet& views, int width,
                           int height, double /*tolerance*/) const {
  detail::check_decode_request(lights, views, width, height);
  Btf out(lights, views, width, height, frame_.format);
  out.set_origin(frame_.origin);
  const std::size_t n = frame_.pixels() * 3;
  const std::ptrdiff_t pairs = std::ptrdiff_t(lights.size() * views.size());
  // Which asked directions are measured, looked up once for all the pairs.
  std::vector<std::optional<std::size_t>> measured_light(lights.size()),
      measured_view(views.size());
  for (std::size_t i = 0; i < lights.size(); ++i) measured_light[i] = frame_.lights.find(lights[i]);
  for (std::size_t i = 0; i < views.size(); ++i) measured_view[i] = frame_.views.find(views[i]);
#pragma omp parallel
  {
    std::vector<float> tile(n), part(n);
    std::vector<double> sum(n);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t p = 0; p < pairs; ++p) {
      const Direction& light = lights[std::size_t(p) / views.size()];
      const Direction& view = views[std::size_t(p) % views.size()];
      const std::optional<std::size_t> li = measured_light[std::size_t(p) / views.size()],
                                       vi = measured_view[std::size_t(p) % views.size()];
      if (li && vi) {
        measured_image(*li, *vi, tile.data());
      } else {
        const auto wv = views_->weights(view);
        std::fill(sum.begin(), sum.end(), 0.0);
        for (std::size_t a = 0; a < 3; ++a) {
          if (wv.weight[a] == 0.0) continue;
          if (li)
            measured_image(*li, wv.index[a], part.data());
          else
            light_image(light, wv.index[a], part.data());
          for (std::size_t i = 0; i < n; ++i) sum[i] += wv.weight[a] * double(part[i]);
        }
        for (std::size_t i = 0; i < n; ++i) tile[i] = float(sum[i]);
      }
      detail::repeat_tile(tile.data(), frame_.width, frame_.height, width, height,
                          out.image(std::size_t(p) / views.size(), std::size_t(p) % views.size()));
    }
  }
  return out;
}

}  // namespace btfgmm
