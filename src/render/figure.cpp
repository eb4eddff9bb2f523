// The comparison of the paper's Fig. 3: RMSE, PSNR and SSIM of two renderings over the
// object, and the figure data | model | difference with the metrics and the scene written
// under it.
#include "btfgmm/render/figure.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/measure/metrics.hpp"
#include "btfgmm/render/font.hpp"
#include "btfgmm/render/render.hpp"

namespace btfgmm {
namespace {

// A level as displayed.
float clamp255(float v) {
  return std::clamp(v, 0.0f, 255.0f);
}

}  // namespace

RenderComparison compare_renderings(const Rendering& a, const Rendering& b) {
  if (a.width != b.width || a.height != b.height || a.rgb.size() != b.rgb.size())
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot compare renderings of {}x{} and {}x{} pixels", a.width,
                            a.height, b.width, b.height));
  const int w = a.width, h = a.height;
  const std::size_t npix = std::size_t(w) * std::size_t(h);
  RenderComparison r;
  double se = 0;
  for (std::size_t p = 0; p < npix; ++p) {
    if (!a.object[p] || !b.object[p]) continue;
    ++r.pixels;
    for (int c = 0; c < 3; ++c) {
      const double d =
          double(clamp255(a.rgb[p * 3 + std::size_t(c)])) - clamp255(b.rgb[p * 3 + std::size_t(c)]);
      se += d * d;
    }
  }
  if (r.pixels == 0)
    throw Error(Error::Kind::kArgument,
                "the object covers no pixel of the renderings; point the camera at it");
  r.rmse = std::sqrt(se / double(3 * r.pixels));
  r.psnr = psnr_db(r.rmse, 255.0);
  // SSIM per channel (metrics.hpp), averaged over the windows centred on the object.
  std::vector<float> x(npix * 3), y(npix * 3);
  for (std::size_t i = 0; i < npix * 3; ++i) {
    x[i] = clamp255(a.rgb[i]);
    y[i] = clamp255(b.rgb[i]);
  }
  const int rad = ssim_radius(w, h);
  const int mw = w - 2 * rad, mh = h - 2 * rad;
  double sum = 0;
  std::size_t count = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> map;
    ssim_channel(x, y, w, h, c, 255.0, {}, &map);
    for (int yy = 0; yy < mh; ++yy)
      for (int xx = 0; xx < mw; ++xx) {
        const std::size_t centre = std::size_t(yy + rad) * std::size_t(w) + std::size_t(xx + rad);
        if (!a.object[centre] || !b.object[centre]) continue;
        sum += map[std::size_t(yy) * std::size_t(mw) + std::size_t(xx)];
        ++count;
      }
  }
  r.ssim = count ? sum / double(count) : std::numeric_limits<double>::quiet_NaN();
  return r;
}

namespace {

// A white image of w x h pixels.
Image blank(int w, int h) {
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.assign(std::size_t(w) * std::size_t(h) * 3, 255.0f);
  return img;
}

// The three panels side by side from row `top`: data, model and the scaled difference.
void draw_panels(Image& img, const Rendering& data, const Rendering& model, int top, int gap,
                 double difference_scale) {
  const int w = data.width, h = data.height;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = (std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3;
      const std::size_t row = std::size_t(y + top) * std::size_t(img.width);
      for (int c = 0; c < 3; ++c) {
        const float a = clamp255(data.rgb[p + std::size_t(c)]),
                    b = clamp255(model.rgb[p + std::size_t(c)]);
        const float d = clamp255(float(difference_scale) * std::abs(a - b));
        img.rgb[(row + std::size_t(x)) * 3 + std::size_t(c)] = a;
        img.rgb[(row + std::size_t(x + w + gap)) * 3 + std::size_t(c)] = b;
        img.rgb[(row + std::size_t(x + 2 * (w + gap))) * 3 + std::size_t(c)] = d;
      }
    }
}

// A horizontal grey ramp from black (0 levels of difference) to white (255 / scale levels and
// more), labelled at both ends, at (x, y), `width` wide, centred in a line of text.
void draw_difference_scale(Image& img, int x, int y, int width, int px, double scale) {
  const std::array<float, 3> ink{0, 0, 0};
  const int bar = std::max(4, px / 2), left = label_width("0 ", px);
  const int top = y + (label_line_height(px) - bar) / 2;
  const std::string high = fmt::format(" {:g} levels or more", 255.0 / scale);
  const int ramp = std::max(8, width - left - label_width(high, px));
  draw_label(img, x, y, "0 ", px, ink);
  for (int i = 0; i < ramp; ++i) {
    const float v = 255.0f * float(i) / float(std::max(1, ramp - 1));
    for (int r = 0; r < bar; ++r) {
      const int yy = top + r;
      if (yy < 0 || yy >= img.height || x + left + i >= img.width) continue;
      float* o =
          &img.rgb[(std::size_t(yy) * std::size_t(img.width) + std::size_t(x + left + i)) * 3];
      o[0] = o[1] = o[2] = v;
    }
  }
  draw_label(img, x + left + ramp, y, high, px, ink);
}

}  // namespace

Image comparison_figure(const Rendering& data, const Rendering& model,
                        const RenderComparison& metrics, double difference_scale,
                        const FigureCaption& caption) {
  if (data.width != model.width || data.height != model.height)
    throw Error(Error::Kind::kArgument, "comparison figure: the renderings differ in size");
  const int w = data.width, h = data.height, gap = std::max(2, w / 200);
  const int px = std::clamp(w / 30, 12, 40), line = label_line_height(px), pad = px / 2;
  const std::vector<std::string> under = {
      fmt::format("RMSE {:.2f} levels · PSNR {:.2f} dB · SSIM {:.3f}, over the {} pixels on "
                  "the object (background left out; compare measures the tile's images)",
                  metrics.rmse, metrics.psnr, metrics.ssim, metrics.pixels)};
  const int text_lines = 2 + int(under.size() + caption.scene.size());
  Image img = blank(3 * w + 2 * gap, h + text_lines * line + 3 * pad);
  const std::array<float, 3> ink{0, 0, 0};
  const std::string model_title =
      caption.model.empty() ? std::string("model") : "model: " + caption.model;
  const std::string titles[3] = {"data (measured)", model_title,
                                 fmt::format("{:g} × |data − model|", difference_scale)};
  for (int k = 0; k < 3; ++k) draw_label(img, k * (w + gap) + pad, pad / 2, titles[k], px, ink);
  const int top = line + pad;
  draw_panels(img, data, model, top, gap, difference_scale);
  int y = top + h + pad / 2;
  draw_difference_scale(img, 2 * (w + gap) + pad, y, w - 2 * pad, px, difference_scale);
  y += line + pad / 2;
  for (const std::string& t : under) y += (draw_label(img, pad, y, t, px, ink), line);
  for (const std::string& t : caption.scene) y += (draw_label(img, pad, y, t, px, ink), line);
  return img;
}

}  // namespace btfgmm
