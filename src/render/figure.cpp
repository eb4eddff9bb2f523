// The comparison of the paper's Fig. 3: RMSE, PSNR and SSIM of two renderings over the
// object, and the figure data | model | difference with the metrics written in a 5 x 7 pixel
// font under it.
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

// A 5 x 7 pixel font: seven rows of five bits (bit 4 the leftmost pixel).
struct Glyph {
  char c;
  std::array<std::uint8_t, 7> rows;
};
constexpr Glyph kFont[] = {
    {'A', {14, 17, 17, 31, 17, 17, 17}}, {'B', {30, 17, 17, 30, 17, 17, 30}},
    {'C', {14, 17, 16, 16, 16, 17, 14}}, {'D', {28, 18, 17, 17, 17, 18, 28}},
    {'E', {31, 16, 16, 30, 16, 16, 31}}, {'F', {31, 16, 16, 30, 16, 16, 16}},
    {'G', {14, 17, 16, 23, 17, 17, 15}}, {'H', {17, 17, 17, 31, 17, 17, 17}},
    {'I', {14, 4, 4, 4, 4, 4, 14}},      {'J', {7, 2, 2, 2, 2, 18, 12}},
    {'K', {17, 18, 20, 24, 20, 18, 17}}, {'L', {16, 16, 16, 16, 16, 16, 31}},
    {'M', {17, 27, 21, 21, 17, 17, 17}}, {'N', {17, 17, 25, 21, 19, 17, 17}},
    {'O', {14, 17, 17, 17, 17, 17, 14}}, {'P', {30, 17, 17, 30, 16, 16, 16}},
    {'Q', {14, 17, 17, 17, 21, 18, 13}}, {'R', {30, 17, 17, 30, 20, 18, 17}},
    {'S', {15, 16, 16, 14, 1, 1, 30}},   {'T', {31, 4, 4, 4, 4, 4, 4}},
    {'U', {17, 17, 17, 17, 17, 17, 14}}, {'V', {17, 17, 17, 17, 17, 10, 4}},
    {'W', {17, 17, 17, 21, 21, 21, 10}}, {'X', {17, 17, 10, 4, 10, 17, 17}},
    {'Y', {17, 17, 17, 10, 4, 4, 4}},    {'Z', {31, 1, 2, 4, 8, 16, 31}},
    {'0', {14, 17, 19, 21, 25, 17, 14}}, {'1', {4, 12, 4, 4, 4, 4, 14}},
    {'2', {14, 17, 1, 2, 4, 8, 31}},     {'3', {31, 2, 4, 2, 1, 17, 14}},
    {'4', {2, 6, 10, 18, 31, 2, 2}},     {'5', {31, 16, 30, 1, 1, 17, 14}},
    {'6', {6, 8, 16, 30, 17, 17, 14}},   {'7', {31, 1, 2, 4, 8, 8, 8}},
    {'8', {14, 17, 17, 14, 17, 17, 14}}, {'9', {14, 17, 17, 15, 1, 2, 12}},
    {'.', {0, 0, 0, 0, 0, 12, 12}},      {',', {0, 0, 0, 0, 12, 4, 8}},
    {':', {0, 12, 12, 0, 12, 12, 0}},    {'/', {0, 1, 2, 4, 8, 16, 0}},
    {'|', {4, 4, 4, 4, 4, 4, 4}},        {'=', {0, 0, 31, 0, 31, 0, 0}},
    {'%', {24, 25, 2, 4, 8, 19, 3}},     {'+', {0, 4, 4, 31, 4, 4, 0}},
    {'-', {0, 0, 0, 31, 0, 0, 0}},       {'(', {2, 4, 8, 8, 8, 4, 2}},
    {')', {8, 4, 2, 2, 2, 4, 8}},        {' ', {0, 0, 0, 0, 0, 0, 0}},
};

const Glyph* glyph(char c) {
  const char u = char(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : kFont)
    if (g.c == u) return &g;
  return nullptr;
}

}  // namespace

void draw_text(Image& image, int x, int y, const std::string& text, int scale,
               std::array<float, 3> rgb) {
  scale = std::max(1, scale);
  int cx = x;
  for (char ch : text) {
    const Glyph* g = glyph(ch);
    if (g)
      for (int row = 0; row < 7; ++row)
        for (int col = 0; col < 5; ++col) {
          if (!((g->rows[std::size_t(row)] >> (4 - col)) & 1)) continue;
          for (int dy = 0; dy < scale; ++dy)
            for (int dx = 0; dx < scale; ++dx) {
              const int px = cx + col * scale + dx, py = y + row * scale + dy;
              if (px < 0 || py < 0 || px >= image.width || py >= image.height) continue;
              float* o =
                  &image.rgb[(std::size_t(py) * std::size_t(image.width) + std::size_t(px)) * 3];
              o[0] = rgb[0];
              o[1] = rgb[1];
              o[2] = rgb[2];
            }
        }
    cx += 6 * scale;
  }
}

Image comparison_figure(const Rendering& data, const Rendering& model,
                        const RenderComparison& metrics, double difference_scale) {
  if (data.width != model.width || data.height != model.height)
    throw Error(Error::Kind::kArgument, "comparison figure: the renderings differ in size");
  const int w = data.width, h = data.height, gap = std::max(2, w / 200);
  const int scale = std::max(1, std::min(w, 900) / 260);
  const int line = 9 * scale, strip = 3 * line + 2 * scale;
  Image img;
  img.width = 3 * w + 2 * gap;
  img.height = h + strip;
  img.rgb.assign(std::size_t(img.width) * std::size_t(img.height) * 3, 255.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t p = (std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3;
      for (int c = 0; c < 3; ++c) {
        const float a = clamp255(data.rgb[p + std::size_t(c)]),
                    b = clamp255(model.rgb[p + std::size_t(c)]);
        const float d = clamp255(float(difference_scale) * std::abs(a - b));
        const std::size_t row = std::size_t(y) * std::size_t(img.width);
        img.rgb[(row + std::size_t(x)) * 3 + std::size_t(c)] = a;
        img.rgb[(row + std::size_t(x + w + gap)) * 3 + std::size_t(c)] = b;
        img.rgb[(row + std::size_t(x + 2 * (w + gap))) * 3 + std::size_t(c)] = d;
      }
    }
  const std::array<float, 3> ink{0, 0, 0};
  const int ty = h + scale;
  draw_text(img, scale, ty, "DATA", scale, ink);
  draw_text(img, w + gap + scale, ty, "MODEL", scale, ink);
  draw_text(img, 2 * (w + gap) + scale, ty, fmt::format("DIFFERENCE X{:g}", difference_scale),
            scale, ink);
  draw_text(img, scale, ty + line,
            fmt::format("RMSE {:.2f}   PSNR {:.2f} DB   SSIM {:.3f}", metrics.rmse, metrics.psnr,
                        metrics.ssim),
            scale, ink);
  return img;
}

}  // namespace btfgmm
