// DataEvaluator: the measured images at any surface point, bilinear in space and interpolated
// over the measured directions (docs/RENDERING.md).
#include <fmt/format.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <limits>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/render/data_evaluator.hpp"
#include "btfgmm/core/fast_interpolation.hpp"
#include "btfgmm/render/render.hpp"
#include "model/conditional.hpp"

namespace btfgmm {

struct DataEvaluator::Impl {
  const Btf* btf;
  FastDirectionInterpolator lights, views;
  explicit Impl(const Btf& b) : btf(&b), lights(b.lights()), views(b.views()) {}
};

DataEvaluator::DataEvaluator(const Btf& btf) {
  if (btf.width() < 1 || btf.height() < 1 || btf.image_count() == 0)
    throw Error(Error::Kind::kArgument, "render: the measured data is empty");
  impl_ = std::make_unique<Impl>(btf);
}
DataEvaluator::~DataEvaluator() = default;
DataEvaluator::DataEvaluator(DataEvaluator&&) noexcept = default;
DataEvaluator& DataEvaluator::operator=(DataEvaluator&&) noexcept = default;

EvaluationStats DataEvaluator::evaluate(std::span<const SurfacePoint> points,
                                        std::span<float> rgb) const {
  if (rgb.size() < points.size() * 3)
    throw Error(Error::Kind::kArgument, "evaluate: the output holds fewer than 3 floats a point");
  const auto t0 = Clock::now();
  const Btf& b = *impl_->btf;
  const int W = b.width(), H = b.height();
  const std::ptrdiff_t n = std::ptrdiff_t(points.size());
#pragma omp parallel
  {
    std::uint32_t hint_l = std::numeric_limits<std::uint32_t>::max(), hint_v = hint_l;
#pragma omp for schedule(dynamic, 256)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const SurfacePoint& p = points[std::size_t(i)];
      const auto wl = impl_->lights.weights(Vec3{p.light[0], p.light[1], p.light[2]}, hint_l);
      const auto wv = impl_->views.weights(Vec3{p.view[0], p.view[1], p.view[2]}, hint_v);
      // Bilinear between the pixels around (x, y), pixel centres at whole coordinates.
      const double x = detail::tile_coordinate(p.x, W), y = detail::tile_coordinate(p.y, H);
      const int xa = int(std::floor(x)) % W, ya = int(std::floor(y)) % H;
      const int xb = (xa + 1) % W, yb = (ya + 1) % H;
      const double fx = x - std::floor(x), fy = y - std::floor(y);
      const std::size_t o00 = (std::size_t(ya) * std::size_t(W) + std::size_t(xa)) * 3,
                        o10 = (std::size_t(ya) * std::size_t(W) + std::size_t(xb)) * 3,
                        o01 = (std::size_t(yb) * std::size_t(W) + std::size_t(xa)) * 3,
                        o11 = (std::size_t(yb) * std::size_t(W) + std::size_t(xb)) * 3;
      const double w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy,
                   w11 = fx * fy;
      std::array<double, 3> c{0, 0, 0};
      for (int a = 0; a < 3; ++a)
        for (int bb = 0; bb < 3; ++bb) {
          const double w = wl.weight[std::size_t(a)] * wv.weight[std::size_t(bb)];
          if (w == 0.0) continue;
          const float* img = b.image(wl.index[std::size_t(a)], wv.index[std::size_t(bb)]);
          for (int ch = 0; ch < 3; ++ch)
            c[std::size_t(ch)] +=
                w * (w00 * img[o00 + std::size_t(ch)] + w10 * img[o10 + std::size_t(ch)] +
                     w01 * img[o01 + std::size_t(ch)] + w11 * img[o11 + std::size_t(ch)]);
        }
      for (int ch = 0; ch < 3; ++ch)
        rgb[std::size_t(i) * 3 + std::size_t(ch)] = float(c[std::size_t(ch)]);
    }
  }
  EvaluationStats st;
  st.points = points.size();
  st.nominal = st.evaluated = std::uint64_t(points.size()) * 36;
  st.seconds = seconds_since(t0);
  return st;
}

}  // namespace btfgmm
