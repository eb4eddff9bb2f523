// Composing images (docs/RENDERING.md): the BTF values of the lit points times the light's
// irradiance and the exposure, on a background; render() evaluates and composes.
#include "btfgmm/render/render.hpp"

#include <algorithm>
#include <cmath>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

Rendering compose(const SurfaceBuffer& s, std::span<const float> point_rgb,
                  const RenderSettings& settings, SampleFormat format) {
  if (point_rgb.size() < s.points.size() * 3)
    throw Error(Error::Kind::kArgument, "compose: fewer colours than surface points");
  Rendering r;
  r.width = s.width;
  r.height = s.height;
  const std::size_t npix = std::size_t(s.width) * std::size_t(s.height);
  r.rgb.resize(npix * 3);
  r.object.resize(npix);
  const std::ptrdiff_t np = std::ptrdiff_t(npix), npoints = std::ptrdiff_t(s.points.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t pi = 0; pi < np; ++pi) {
    const std::size_t p = std::size_t(pi);
    r.object[p] = s.coverage[p] != 0;
    for (int c = 0; c < 3; ++c)
      r.rgb[p * 3 + std::size_t(c)] =
          s.coverage[p] == 0 ? settings.background[std::size_t(c)] : 0.0f;
  }
  const double scale = std::exp2(settings.exposure);
  // Each point has a pixel of its own.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t pi = 0; pi < npoints; ++pi) {
    const std::size_t i = std::size_t(pi), p = s.pixel[i];
    for (int c = 0; c < 3; ++c) {
      double v = double(point_rgb[i * 3 + std::size_t(c)]) * s.points[i].irradiance * scale;
      if (format == SampleFormat::kHdr) {
        // Linear to sRGB levels.
        v = std::clamp(v, 0.0, 1.0);
        v = 255.0 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055);
      }
      r.rgb[p * 3 + std::size_t(c)] = float(v);
    }
  }
  r.geometry_seconds = s.seconds;
  return r;
}

namespace {

// Every lit point through `evaluate` (the evaluator's colours), then composed.
template <class Evaluate>
Rendering render_with(const SurfaceBuffer& surface, const RenderSettings& settings,
                      SampleFormat format, Evaluate evaluate) {
  std::vector<float> rgb(surface.points.size() * 3);
  const EvaluationStats st = evaluate(rgb);
  Rendering r = compose(surface, rgb, settings, format);
  r.stats = st;
  return r;
}

}  // namespace

Rendering render(const SurfaceBuffer& surface, const ModelEvaluator& model,
                 const RenderSettings& settings, SampleFormat format) {
  return render_with(surface, settings, format, [&](std::span<float> rgb) {
    return model.evaluate(surface.points, rgb, surface.block_start);
  });
}

Rendering render(const SurfaceBuffer& surface, const RepresentationEvaluator& model,
                 const RenderSettings& settings, SampleFormat format) {
  return render_with(surface, settings, format, [&](std::span<float> rgb) {
    return model.evaluate(surface.points, rgb, surface.block_start);
  });
}

Rendering render(const SurfaceBuffer& surface, const DataEvaluator& data,
                 const RenderSettings& settings, SampleFormat format) {
  return render_with(surface, settings, format,
                     [&](std::span<float> rgb) { return data.evaluate(surface.points, rgb); });
}

}  // namespace btfgmm
