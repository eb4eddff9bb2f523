// The comparison of a model with its BTF tile, its pictures and curves, and the HTML report;
// see report.hpp and docs/METRICS.md.
#include "btfgmm/report/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>

#include "btfgmm/core/error.hpp"
#include "btfgmm/model/predict.hpp"

namespace btfgmm {

namespace fs = std::filesystem;

namespace {

constexpr const char* kPalette[] = {"#2563eb", "#dc2626", "#16a34a", "#9333ea",
                                    "#ea580c", "#0891b2", "#be185d", "#4d7c0f"};
constexpr std::size_t kPaletteSize = sizeof(kPalette) / sizeof(kPalette[0]);

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  return out;
}

double srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

std::string angles(const Direction& d) {
  return fmt::format("&theta; {:g}&deg; &phi; {:g}&deg;", d.theta_deg, d.phi_deg);
}

std::string db(double v) {
  return std::isfinite(v) ? fmt::format("{:.2f}", v) : std::string("&infin;");
}

// RMSE for people: levels with 2 decimals; HDR data (any scale) with 4 significant digits.
std::string rmse_text(double v, SampleFormat f) {
  return f == SampleFormat::kHdr ? fmt::format("{:.4g}", v) : fmt::format("{:.2f}", v);
}

std::string ratio(double r) {
  return r >= 100 ? fmt::format("1:{:.0f}", r) : fmt::format("1:{:.1f}", r);
}

std::string kib(std::uint64_t bytes) {
  const double b = double(bytes);
  if (b < 1024) return fmt::format("{} B", bytes);
  if (b < 1024.0 * 1024.0) return fmt::format("{:.1f} KiB", b / 1024.0);
  return fmt::format("{:.2f} MiB", b / (1024.0 * 1024.0));
}

std::string seconds(double s) {
  if (s < 60) return fmt::format("{:.1f} s", s);
  const long t = std::lround(s);
  if (t < 3600) return fmt::format("{}:{:02d} min", t / 60, t % 60);
  return fmt::format("{}:{:02d}:{:02d} h", t / 3600, (t / 60) % 60, t % 60);
}

std::size_t extreme_theta(const DirectionSet& s, bool largest) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < s.size(); ++i)
    if (largest ? s[i].theta_deg > s[best].theta_deg : s[i].theta_deg < s[best].theta_deg) best = i;
  return best;
}

// ---- SVG helpers ----------------------------------------------------------------------------

double nice_step(double span, int target) {
  if (!(span > 0)) return 1.0;
  const double raw = span / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  return (f <= 1.0 ? 1.0 : f <= 2.0 ? 2.0 : f <= 2.5 ? 2.5 : f <= 5.0 ? 5.0 : 10.0) * mag;
}

std::string tick_text(double v, double step) {
  int decimals = 0;
  while (decimals < 6 && std::abs(step * std::pow(10.0, decimals) -
                                  std::round(step * std::pow(10.0, decimals))) > 1e-6)
    ++decimals;
  if (std::abs(v) < step * 1e-9) v = 0.0;
  return fmt::format("{:.{}f}", v, decimals);
}

struct Axis {
  double lo = 0, hi = 1, step = 1;
};

Axis make_axis(double lo, double hi, bool from_zero, int ticks) {
  if (from_zero) lo = std::min(lo, 0.0), hi = std::max(hi, 0.0);
  if (!(hi > lo)) {
    const double pad = std::abs(lo) > 0 ? std::abs(lo) * 0.1 : 1.0;
    lo -= pad;
    hi += pad;
    if (from_zero) lo = std::min(0.0, lo + pad);
  } else {
    // A little room so that no point sits on the frame (none below zero when from zero).
    const double pad = 0.04 * (hi - lo);
    hi += pad;
    if (!from_zero || lo < 0.0) lo -= pad;
  }
  Axis a;
  a.step = nice_step(hi - lo, ticks);
  a.lo = std::floor(lo / a.step + 1e-9) * a.step;
  a.hi = std::ceil(hi / a.step - 1e-9) * a.step;
  if (a.hi <= a.lo) a.hi = a.lo + a.step;
  return a;
}

// Ticks at the first direction of each elevation ring of a set (the rows or columns of a
// (light, view) grid): index and theta.
std::vector<std::pair<std::size_t, double>> ring_starts(const DirectionSet& s) {
  std::vector<std::pair<std::size_t, double>> out;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (i == 0 || s[i].theta_deg != s[i - 1].theta_deg) out.push_back({i, s[i].theta_deg});
  return out;
}

// A (light, view) grid picture with ring ticks on both axes: rows = lights, columns = views.
// `outline` pairs are marked with a square.
std::string grid_svg(const std::string& png, const DirectionSet& lights, const DirectionSet& views,
                     int cell, const std::vector<std::pair<std::size_t, std::size_t>>& outline,
                     const std::string& legend_svg, int legend_width) {
  const int gw = int(views.size()) * cell, gh = int(lights.size()) * cell;
  const int left = 46, top = 30, bottom = 8;
  const int width = left + gw + 8 + legend_width, height = top + gh + bottom;
  std::string s = fmt::format(
      "<svg width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" font-family=\"system-ui, sans-serif\" "
      "font-size=\"10\">",
      width, height, width, height);
  s += fmt::format(
      "<image href=\"{}\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" "
      "style=\"image-rendering:pixelated\"/>",
      escape(png), left, top, gw, gh);
  s += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" "
      "stroke=\"#9ca3af\"/>",
      left - 0.5, top - 0.5, gw + 1, gh + 1);
  // Axis marks: for sets of a few elevation rings (such as the 81 of UBO2003), a tick where
  // each ring starts and its theta at the middle of its run (where two labels would collide,
  // the later, larger ring keeps its own); for sets without rings (a spiral), every tenth or so
  // index.
  struct Marks {
    std::vector<double> ticks;
    std::vector<std::pair<double, std::string>> labels;
    bool rings = true;
  };
  auto marks = [&](const DirectionSet& set, double gap) {
    Marks m;
    const auto starts = ring_starts(set);
    if (starts.size() <= 16) {
      for (std::size_t r = 0; r < starts.size(); ++r) {
        const double end = r + 1 < starts.size() ? double(starts[r + 1].first) : double(set.size());
        const double at = 0.5 * (double(starts[r].first) + end) * cell;
        m.ticks.push_back(double(starts[r].first) * cell);
        if (!m.labels.empty() && at - m.labels.back().first < gap) m.labels.pop_back();
        m.labels.push_back({at, fmt::format("{:g}&deg;", starts[r].second)});
      }
    } else {
      m.rings = false;
      const double step = std::max(1.0, nice_step(double(set.size()), 6));
      for (double i = 0; i < double(set.size()); i += step) {
        m.ticks.push_back(i * cell);
        m.labels.push_back({(i + 0.5) * cell, fmt::format("{:g}", i)});
      }
    }
    return m;
  };
  // Columns: views, on top.
  const Marks vm = marks(views, 26);
  s += fmt::format(
      "<text x=\"{}\" y=\"10\" text-anchor=\"middle\" fill=\"#374151\">view {} (columns) "
      "&#8594;</text>",
      left + gw / 2, vm.rings ? "&theta;" : "index");
  for (double t : vm.ticks)
    s += fmt::format("<line x1=\"{0}\" x2=\"{0}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#6b7280\"/>",
                     left + t, top - 5, top);
  for (const auto& [at, text] : vm.labels)
    s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#4b5563\">{}</text>",
                     left + at, top - 7, text);
  // Rows: lights, on the left.
  const Marks lm = marks(lights, 12);
  s += fmt::format(
      "<text transform=\"translate(10 {}) rotate(-90)\" text-anchor=\"middle\" "
      "fill=\"#374151\">light {} (rows) &#8594;</text>",
      top + gh / 2, lm.rings ? "&theta;" : "index");
  for (double t : lm.ticks)
    s += fmt::format("<line x1=\"{0}\" x2=\"{1}\" y1=\"{2}\" y2=\"{2}\" stroke=\"#6b7280\"/>",
                     left - 5, left, top + t);
  for (const auto& [at, text] : lm.labels)
    s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\" fill=\"#4b5563\">{}</text>",
                     left - 7, top + at + 3.5, text);
  for (const auto& [l, v] : outline)
    s += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" "
        "stroke=\"#ef4444\" stroke-width=\"1.5\"/>",
        left + int(v) * cell - 2, top + int(l) * cell - 2, cell + 4, cell + 4);
  if (!legend_svg.empty())
    s += fmt::format("<g transform=\"translate({} {})\">{}</g>", left + gw + 8, top, legend_svg);
  s += "</svg>";
  return s;
}

// A vertical colour bar of the viridis map from lo_db (bottom) to hi_db (top).
std::string colour_bar(double lo_db, double hi_db, int height, const std::string& id) {
  std::string s = "<defs><linearGradient id=\"" + id + "\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">";
  for (int i = 0; i <= 8; ++i) {
    const auto c = colour_map(i / 8.0);
    s += fmt::format("<stop offset=\"{}\" stop-color=\"rgb({},{},{})\"/>", i / 8.0, int(c[0]),
                     int(c[1]), int(c[2]));
  }
  s += "</linearGradient></defs>";
  s += fmt::format(
      "<rect x=\"0\" y=\"0\" width=\"14\" height=\"{}\" fill=\"url(#{})\" "
      "stroke=\"#9ca3af\"/>",
      height, id);
  const Axis a = make_axis(lo_db, hi_db, false, 6);
  for (double v = a.lo; v <= hi_db + 1e-9; v += a.step) {
    if (v < lo_db - 1e-9) continue;
    const double y = height - (v - lo_db) / (hi_db - lo_db) * height;
    s += fmt::format(
        "<line x1=\"14\" x2=\"18\" y1=\"{0}\" y2=\"{0}\" stroke=\"#374151\"/>"
        "<text x=\"20\" y=\"{1}\" fill=\"#374151\">{2}</text>",
        y, y + 3.5, tick_text(v, a.step));
  }
  s += "<text x=\"0\" y=\"-8\" fill=\"#374151\">dB</text>";
  return s;
}

}  // namespace

// ---- the comparison -----------------------------------------------------------------------

ModelComparison compare_model(const Btf& original, const BtfModel& model, const std::string& name,
                              std::uint64_t file_bytes, const CompareOptions& options) {
  if (!(original.lights() == model.lights) || !(original.views() == model.views))
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: the model was fitted to {} lights x {} views, the BTF has {} x {} "
                            "or other angles; compare a model with the BTF it was fitted to",
                            name, model.lights.size(), model.views.size(), original.lights().size(),
                            original.views().size()));
  if (original.width() != model.width || original.height() != model.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("{}: the model's tile is {}x{} pixels, the original {}x{}; load the "
                            "model's tile (origin and size) from the BTF",
                            name, model.width, model.height, original.width(), original.height()));
  const Btf decoded = decode(model, model.lights, model.views, model.width, model.height);
  ModelComparison c;
  c.name = name;
  c.model = model;
  c.file_bytes = file_bytes;
  c.tile = {model.origin.x, model.origin.y, model.width, model.height};
  c.quality = measure_quality(original, decoded, 0.0, options.ssim);
  c.mean_brdf = mean_brdf(original);
  {
    Btf mean_only(original.lights(), original.views(), original.width(), original.height(),
                  original.format());
    const std::size_t pixels = std::size_t(original.width()) * std::size_t(original.height());
    for (std::size_t i = 0; i < original.image_count(); ++i)
      for (std::size_t p = 0; p < pixels; ++p)
        for (std::size_t k = 0; k < 3; ++k)
          mean_only.data()[i * original.image_floats() + p * 3 + k] = c.mean_brdf[i * 3 + k];
    c.mean_brdf_only = measure_quality(original, mean_only, c.quality.range, options.ssim);
  }

  const std::size_t nv = original.views().size();
  const std::size_t floats = original.image_floats();
  auto add = [&](std::size_t l, std::size_t v, const std::string& label) {
    for (PicturedPair& p : c.pairs)
      if (p.light == l && p.view == v) {
        p.label += ", " + label;
        return;
      }
    PicturedPair p;
    p.light = l;
    p.view = v;
    p.label = label;
    p.original.assign(original.image(l, v), original.image(l, v) + floats);
    p.model.assign(decoded.image(l, v), decoded.image(l, v) + floats);
    c.pairs.push_back(std::move(p));
  };
  const std::size_t fl = extreme_theta(original.lights(), false),
                    gl = extreme_theta(original.lights(), true),
                    fv = extreme_theta(original.views(), false),
                    gv = extreme_theta(original.views(), true);
  add(fl, fv, "frontal light and view");
  add(gl, fv, "grazing light");
  add(fl, gv, "grazing view");
  const std::vector<std::size_t> order = c.quality.by_psnr();
  for (std::size_t k = 0; k < std::min(options.worst_pairs, order.size()); ++k)
    add(order[k] / nv, order[k] % nv, fmt::format("worst PSNR {}", k + 1));
  return c;
}

// ---- pictures -----------------------------------------------------------------------------

Image display_image(std::span<const float> rgb, int width, int height, SampleFormat format,
                    double range) {
  Image out;
  out.width = width;
  out.height = height;
  out.rgb.resize(rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i)
    out.rgb[i] = format == SampleFormat::kHdr ? float(255.0 * srgb_encode(double(rgb[i]) / range))
                                              : std::clamp(rgb[i], 0.0f, 255.0f);
  return out;
}

Image difference_image(std::span<const float> original, std::span<const float> model, int width,
                       int height, SampleFormat format, double range, double scale) {
  if (original.size() != model.size() ||
      original.size() != std::size_t(width) * std::size_t(height) * 3)
    throw Error(Error::Kind::kArgument,
                fmt::format("difference image: {}x{} pixels need {} values in both images, they "
                            "hold {} and {}",
                            width, height, std::size_t(width) * std::size_t(height) * 3,
                            original.size(), model.size()));
  const double to_levels = format == SampleFormat::kHdr ? 255.0 / range : 1.0;
  Image out;
  out.width = width;
  out.height = height;
  out.rgb.resize(original.size());
  for (std::size_t i = 0; i < original.size(); ++i)
    out.rgb[i] = float(
        std::min(255.0, scale * std::abs(double(original[i]) - double(model[i])) * to_levels));
  return out;
}

Image upscale_nearest(const Image& image, int factor) {
  if (factor < 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("upscale: factor {} must be at least 1", factor));
  Image out;
  out.width = image.width * factor;
  out.height = image.height * factor;
  out.format = image.format;
  out.rgb.resize(std::size_t(out.width) * std::size_t(out.height) * 3);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int k = 0; k < 3; ++k)
        out.rgb[(std::size_t(y) * std::size_t(out.width) + std::size_t(x)) * 3 + std::size_t(k)] =
            image.rgb[(std::size_t(y / factor) * std::size_t(image.width) +
                       std::size_t(x / factor)) *
                          3 +
                      std::size_t(k)];
  return out;
}

Image mean_brdf_image(std::span<const float> mean_brdf, std::size_t lights, std::size_t views,
                      SampleFormat format) {
  if (mean_brdf.size() != lights * views * 3 || lights == 0 || views == 0)
    throw Error(Error::Kind::kArgument,
                fmt::format("mean BRDF image: {} lights x {} views need {} values, given {}",
                            lights, views, lights * views * 3, mean_brdf.size()));
  float peak = 0.0f;
  for (float v : mean_brdf) peak = std::max(peak, v);
  const double scale = peak > 0.0f ? 1.0 / double(peak) : 1.0;
  Image out;
  out.width = int(views);
  out.height = int(lights);
  out.rgb.resize(mean_brdf.size());
  // Light-major values are already rows = lights, columns = views.
  for (std::size_t i = 0; i < mean_brdf.size(); ++i) {
    const double v = std::max(0.0, double(mean_brdf[i]) * scale);
    out.rgb[i] = float(255.0 * (format == SampleFormat::kHdr ? srgb_encode(v) : v));
  }
  return out;
}

std::array<float, 3> colour_map(double t) {
  // viridis (matplotlib), sampled at 9 points and interpolated linearly.
  static constexpr float kViridis[9][3] = {{68, 1, 84},    {71, 44, 122},  {59, 81, 139},
                                           {44, 113, 142}, {33, 144, 141}, {39, 173, 129},
                                           {92, 200, 99},  {170, 220, 50}, {253, 231, 37}};
  if (!(t > 0.0)) t = 0.0;  // also NaN
  t = std::min(t, 1.0) * 8.0;
  const int i = std::min(7, int(t));
  const float f = float(t - i);
  return {kViridis[i][0] + f * (kViridis[i + 1][0] - kViridis[i][0]),
          kViridis[i][1] + f * (kViridis[i + 1][1] - kViridis[i][1]),
          kViridis[i][2] + f * (kViridis[i + 1][2] - kViridis[i][2])};
}

std::array<double, 2> psnr_map_range(const BtfQuality& quality) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const ImageQuality& q : quality.images)
    if (std::isfinite(q.psnr_db)) {
      lo = std::min(lo, q.psnr_db);
      hi = std::max(hi, q.psnr_db);
    }
  if (!std::isfinite(lo)) return {0.0, 1.0};
  lo = std::floor(lo);
  hi = std::ceil(hi);
  if (hi <= lo) hi = lo + 1.0;
  return {lo, hi};
}

Image psnr_map_image(const BtfQuality& quality, double lo_db, double hi_db) {
  Image out;
  out.width = int(quality.views);
  out.height = int(quality.lights);
  out.rgb.resize(quality.images.size() * 3);
  const double span = hi_db > lo_db ? hi_db - lo_db : 1.0;
  for (std::size_t i = 0; i < quality.images.size(); ++i) {
    const double p = quality.images[i].psnr_db;
    const auto c = colour_map(std::isfinite(p) ? (p - lo_db) / span : 1.0);
    for (std::size_t k = 0; k < 3; ++k) out.rgb[i * 3 + k] = c[k];
  }
  return out;
}

// ---- curves -------------------------------------------------------------------------------

std::string svg_chart(const Chart& chart) {
  const int left = 62, right = 14, top = 30, bottom = 44;
  const int pw = chart.width - left - right, ph = chart.height - top - bottom;
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : chart.series)
    for (const auto& p : s.points) {
      if (!std::isfinite(p[0]) || !std::isfinite(p[1])) continue;
      x0 = std::min(x0, p[0]);
      x1 = std::max(x1, p[0]);
      y0 = std::min(y0, p[1]);
      y1 = std::max(y1, p[1]);
    }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  Axis ax = make_axis(x0, x1, chart.x_from_zero, 5);
  if (chart.x_integer && ax.step < 1.0) {  // no ticks between whole numbers
    ax.step = 1.0;
    ax.lo = std::floor(ax.lo);
    ax.hi = std::ceil(ax.hi);
  } else if (chart.x_integer && ax.step != std::floor(ax.step)) {
    ax.step = std::ceil(ax.step);
    ax.hi = ax.lo + std::ceil((ax.hi - ax.lo) / ax.step) * ax.step;
  }
  const Axis ay = make_axis(y0, y1, chart.y_from_zero, 5);
  auto px = [&](double x) { return left + (x - ax.lo) / (ax.hi - ax.lo) * pw; };
  auto py = [&](double y) { return top + ph - (y - ay.lo) / (ay.hi - ay.lo) * ph; };

  // The legend goes below the axes, one row per labelled series.
  const int rows = int(std::count_if(chart.series.begin(), chart.series.end(),
                                     [](const ChartSeries& c) { return !c.label.empty(); }));
  const int total_height = chart.height + 15 * rows + (rows ? 6 : 0);
  std::string s = fmt::format(
      "<svg class=\"chart\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"system-ui, sans-serif\" font-size=\"11\">",
      chart.width, total_height);
  s += fmt::format(
      "<text x=\"{}\" y=\"16\" font-size=\"13\" font-weight=\"600\" "
      "fill=\"#111827\">{}</text>",
      left - 50, escape(chart.title));
  for (double v = ax.lo; v <= ax.hi + ax.step * 1e-6; v += ax.step) {
    const double x = px(v);
    s += fmt::format(
        "<line x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#e5e7eb\"/>"
        "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\" fill=\"#4b5563\">{4}"
        "</text>",
        x, top, top + ph, top + ph + 14, tick_text(v, ax.step));
  }
  for (double v = ay.lo; v <= ay.hi + ay.step * 1e-6; v += ay.step) {
    const double y = py(v);
    s += fmt::format(
        "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\" stroke=\"#e5e7eb\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\" fill=\"#4b5563\">{5}</text>",
        left, left + pw, y, left - 5, y + 3.5, tick_text(v, ay.step));
  }
  s += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" "
      "stroke=\"#9ca3af\"/>",
      left, top, pw, ph);
  s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#374151\">{}</text>",
                   left + pw / 2, chart.height - 8, escape(chart.x_label));
  s += fmt::format(
      "<text transform=\"translate(14 {}) rotate(-90)\" text-anchor=\"middle\" "
      "fill=\"#374151\">{}</text>",
      top + ph / 2, escape(chart.y_label));

  s += "<g>";
  for (const auto& series : chart.series) {
    std::string pts;
    for (const auto& p : series.points)
      if (std::isfinite(p[0]) && std::isfinite(p[1]))
        pts += fmt::format("{:.1f},{:.1f} ", px(p[0]), py(p[1]));
    if (series.line && !pts.empty())
      s += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"2\"{}/>",
                       pts, series.colour, series.dashed ? " stroke-dasharray=\"6 4\"" : "");
    if (series.markers)
      for (const auto& p : series.points)
        if (std::isfinite(p[0]) && std::isfinite(p[1]))
          s += fmt::format(
              "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\" fill=\"{}\" stroke=\"{}\" "
              "stroke-width=\"1.5\"/>",
              px(p[0]), py(p[1]), series.hollow ? "#fff" : series.colour, series.colour);
  }
  s += "</g>";
  // Legend, below the axes.
  int row = 0;
  for (const auto& series : chart.series) {
    if (series.label.empty()) continue;
    const int y = chart.height + 12 + 15 * row++;
    const int x = left;
    if (series.line)
      s += fmt::format(
          "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2}\" y2=\"{2}\" stroke=\"{3}\" "
          "stroke-width=\"2\"{4}/>",
          x, x + 20, y - 3, series.colour, series.dashed ? " stroke-dasharray=\"6 4\"" : "");
    if (series.markers)
      s += fmt::format(
          "<circle cx=\"{}\" cy=\"{}\" r=\"4\" fill=\"{}\" stroke=\"{}\" "
          "stroke-width=\"1.5\"/>",
          x + 10, y - 3, series.hollow ? "#fff" : series.colour, series.colour);
    s += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"#111827\">{}</text>", x + 26, y + 1,
                     escape(series.label));
  }
  s += "</svg>";
  return s;
}

Chart compression_ratio_chart(std::span<const ModelComparison> models) {
  if (models.empty())
    throw Error(Error::Kind::kArgument, "compression ratio chart: give at least one model");
  const std::size_t ni = models[0].model.lights.size(), nv = models[0].model.views.size();
  double max_pixels = 4096.0;  // the paper's 64 x 64 fit
  std::set<std::size_t> ms{600};
  for (const auto& m : models) {
    max_pixels = std::max(max_pixels, 1.25 * double(m.model.width) * double(m.model.height));
    ms.insert(m.model.mixture.size());
  }
  Chart c;
  c.title = fmt::format("Compression ratio against tile size ({} x {} directions)", ni, nv);
  c.x_label = "tile size W·H (pixels)";
  c.y_label = "compression ratio 1:x";
  c.x_from_zero = c.y_from_zero = true;
  std::size_t colour = 0;
  for (std::size_t m : ms) {
    ChartSeries s;
    s.points = {{0.0, 0.0}, {max_pixels, paper_compression_ratio(max_pixels, ni, nv, m)}};
    const bool used = std::any_of(models.begin(), models.end(),
                                  [&](const auto& x) { return x.model.mixture.size() == m; });
    if (used) {
      s.label = fmt::format("M = {}", m);
      s.colour = kPalette[colour++ % kPaletteSize];
    } else {
      s.label = fmt::format("M = {} (the paper's setting)", m);
      s.colour = "#9ca3af";
      s.dashed = true;
    }
    c.series.push_back(s);
  }
  ChartSeries paper, file;
  paper.label = "models compared, paper's count";
  file.label = "models compared, file bytes";
  paper.colour = file.colour = "#111827";
  paper.line = file.line = false;
  paper.markers = file.markers = true;
  file.hollow = true;
  for (const auto& m : models) {
    const double px = double(m.model.width) * double(m.model.height);
    paper.points.push_back({px, m.model.compression_ratio_paper()});
    if (m.file_bytes > 0) file.points.push_back({px, m.model.compression_ratio_file(m.file_bytes)});
  }
  c.series.push_back(paper);
  if (!file.points.empty()) c.series.push_back(file);
  if (ni == 81 && nv == 81) {
    ChartSeries t2;
    t2.label = "paper, Table 2: 25×25, M = 600 (195.6)";
    t2.colour = "#f59e0b";
    t2.line = false;
    t2.markers = true;
    t2.points = {{625.0, 195.6}};
    c.series.push_back(t2);
  }
  return c;
}

// ---- the report ---------------------------------------------------------------------------

namespace {

void save_png(const fs::path& folder, const std::string& name, const Image& image) {
  write_png(folder / name, image.width, image.height, image.rgb);
}

int upscale_for(int largest, int target) {
  return std::max(1, (target + largest - 1) / largest);
}

std::string cards(const ModelComparison& c) {
  const BtfQuality& q = c.quality;
  const auto& worst = q.images[q.worst_psnr];
  auto card = [](const std::string& k, const std::string& v, const std::string& sub) {
    return fmt::format(
        "<div class=\"card\"><div class=\"k\">{}</div><div class=\"v\">{}</div>"
        "<div class=\"s\">{}</div></div>",
        k, v, sub);
  };
  std::string s = "<div class=\"cards\">";
  s += card("PSNR", db(q.psnr_db) + " <small>dB</small>",
            fmt::format("worst image {} dB &middot; mean BRDF alone {} dB", db(worst.psnr_db),
                        db(c.mean_brdf_only.psnr_db)));
  s += card("SSIM", fmt::format("{:.3f}", q.ssim),
            fmt::format("worst image {:.3f} &middot; mean BRDF alone {:.3f}",
                        q.images[q.worst_ssim].ssim, c.mean_brdf_only.ssim));
  s += card("RMSE", rmse_text(q.rmse, c.model.format),
            fmt::format("{} &middot; mean BRDF alone {}",
                        c.model.format == SampleFormat::kHdr ? "data units" : "levels of 0-255",
                        rmse_text(c.mean_brdf_only.rmse, c.model.format)));
  s += card("Compression", ratio(c.model.compression_ratio_paper()),
            c.file_bytes > 0 ? fmt::format("paper's count &middot; file {} ({})",
                                           ratio(c.model.compression_ratio_file(c.file_bytes)),
                                           kib(c.file_bytes))
                             : std::string("paper's count"));
  s += card(
      "Components", fmt::format("M = {}", c.model.mixture.size()),
      fmt::format("{} requested, {} dropped &middot; {} iterations", c.model.settings.components,
                  c.model.settings.dropped, c.model.settings.iterations));
  s += "</div>";
  return s;
}

std::string tile_text(const Tile& t) {
  return fmt::format("{}&times;{} at ({}, {})", t.width, t.height, t.x, t.y);
}

}  // namespace

void write_report(const fs::path& folder, const std::string& btf_name,
                  std::span<const ModelComparison> models) {
  if (models.empty())
    throw Error(Error::Kind::kArgument, "report: give at least one model to compare");
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec || !fs::is_directory(folder))
    throw Error(Error::Kind::kIo, fmt::format("report: cannot create the folder '{}': {}; check "
                                              "the path and its permissions",
                                              folder.string(), ec.message()));
  const ModelComparison& first = models[0];
  const BtfModel& m0 = first.model;
  const bool hdr = m0.format == SampleFormat::kHdr;

  std::string h;
  h += "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">";
  h += fmt::format("<title>btfgmm compare: {}</title>", escape(btf_name));
  h += R"(<style>
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;color:#1f2937;background:#f3f4f6;margin:0}
main{max-width:1360px;margin:0 auto;padding:16px 22px}
h1{font-size:21px;margin:0 0 2px}h2{font-size:16px;margin:0 0 10px}h3{font-size:13px;margin:0 0 6px;color:#374151}
.sub{color:#4b5563;margin:0 0 12px}
section{background:#fff;border:1px solid #e5e7eb;border-radius:8px;padding:12px 16px;margin:0 0 12px}
.cards{display:flex;gap:10px;flex-wrap:wrap;margin:0 0 12px}
.card{flex:1;min-width:170px;background:#fff;border:1px solid #e5e7eb;border-radius:8px;padding:8px 12px}
.card .k{color:#6b7280;font-size:11px;text-transform:uppercase;letter-spacing:.05em}
.card .v{font-size:26px;font-weight:650;line-height:1.2}.card .v small{font-size:14px;font-weight:500;color:#6b7280}
.card .s{color:#6b7280;font-size:12px}
table{border-collapse:collapse;font-variant-numeric:tabular-nums;font-size:13px}
th,td{padding:3px 9px;border-bottom:1px solid #e5e7eb;text-align:right;white-space:nowrap}
th{background:#f9fafb;font-weight:600}td:first-child,th:first-child{text-align:left}
tr.base td{color:#6b7280;font-style:italic}
.detail{display:flex;gap:22px;align-items:flex-start;flex-wrap:wrap}
.pairs{display:grid;grid-template-columns:repeat(2,auto);gap:10px 22px}
figure{margin:0}.imgs{display:flex;gap:3px}.imgs span{display:block;font-size:11px;color:#6b7280;text-align:center}
img{image-rendering:pixelated;display:block;outline:1px solid #d1d5db}
figcaption{font-size:12px;color:#374151;margin-top:2px}figcaption b{color:#111827}
.maps{display:flex;flex-direction:column;gap:8px;flex:0 0 auto}
.curves{display:flex;gap:14px;flex-wrap:wrap}
.note{color:#6b7280;font-size:12px;margin:6px 0 0}
code{font-size:12px;background:#f3f4f6;padding:0 3px;border-radius:3px}
.notes li{margin:2px 0;font-size:13px}
</style></head><body><main>
)";
  h += fmt::format("<h1>btfgmm compare: <code>{}</code></h1>", escape(btf_name));
  h += fmt::format(
      "<p class=\"sub\">{} light &times; {} view directions ({} images) &middot; {} data &middot; "
      "{} model{} compared &middot; tile {}</p>",
      m0.lights.size(), m0.views.size(), m0.lights.size() * m0.views.size(), to_string(m0.format),
      models.size(), models.size() == 1 ? "" : "s", tile_text(first.tile));

  if (models.size() == 1) h += cards(first);

  // The table of models.
  h += "<section><h2>Models</h2><table><tr><th>model</th><th>tile</th><th>M</th><th>iterations"
       "</th><th>RMSE</th><th>PSNR dB</th><th>SSIM</th><th>worst image PSNR (light; view)</th>"
       "<th>C.R. paper</th><th>C.R. file</th><th>file</th><th>fit time</th></tr>";
  std::vector<Tile> tiles_with_baseline;
  for (const ModelComparison& c : models) {
    const BtfQuality& q = c.quality;
    const std::size_t w = q.worst_psnr;
    h += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{} <span class=\"note\">({} req.)</span></td><td>{}</td>"
        "<td>{}</td><td>{}</td><td>{:.3f}</td><td>{} ({}; {})</td><td>{}</td><td>{}</td>"
        "<td>{}</td><td>{}</td></tr>",
        escape(c.name), tile_text(c.tile), c.model.mixture.size(), c.model.settings.components,
        c.model.settings.iterations, rmse_text(q.rmse, c.model.format), db(q.psnr_db), q.ssim,
        db(q.images[w].psnr_db), angles(c.model.lights[w / q.views]),
        angles(c.model.views[w % q.views]), ratio(c.model.compression_ratio_paper()),
        c.file_bytes ? ratio(c.model.compression_ratio_file(c.file_bytes)) : "",
        c.file_bytes ? kib(c.file_bytes) : "",
        // Not stored in model files (they are reproducible): blank when unknown.
        c.model.settings.seconds > 0 ? seconds(c.model.settings.seconds) : std::string());
  }
  for (const ModelComparison& c : models) {
    const bool seen =
        std::any_of(tiles_with_baseline.begin(), tiles_with_baseline.end(), [&](const Tile& t) {
          return t.x == c.tile.x && t.y == c.tile.y && t.width == c.tile.width &&
                 t.height == c.tile.height;
        });
    if (seen) continue;
    tiles_with_baseline.push_back(c.tile);
    const BtfQuality& b = c.mean_brdf_only;
    h += fmt::format(
        "<tr class=\"base\"><td>mean BRDF alone</td><td>{}</td><td>0</td><td></td><td>{}</td>"
        "<td>{}</td><td>{:.3f}</td><td>{}</td><td></td><td></td><td></td><td></td></tr>",
        tile_text(c.tile), rmse_text(b.rmse, c.model.format), db(b.psnr_db), b.ssim,
        db(b.images[b.worst_psnr].psnr_db));
  }
  h += "</table><p class=\"note\">The paper (Fig. 3, M = 600, 81 &times; 81 directions): "
       "corduroy 36&times;46 1:518, RMSE 15 / PSNR 24.8 dB / SSIM 0.81; knitted wool 25&times;25 "
       "1:196, 12 / 26.5 / 0.85; aluminium profile 21&times;26 1:171, 7.3 / 30.9 / 0.90. "
       "&ldquo;Mean BRDF alone&rdquo;: every pixel its image's mean colour, the model without "
       "its mixture.</p></section>\n";

  // Curves: right after the table for a sweep of models, after the pictures for one model.
  std::string curves = "<section><h2>Curves</h2><div class=\"curves\">";
  curves += svg_chart(compression_ratio_chart(models));
  {
    Chart c;
    c.title = "PSNR against the number of components M";
    c.x_label = "components M";
    c.x_integer = true;
    c.y_label = "PSNR (dB)";
    c.x_from_zero = true;
    std::vector<const ModelComparison*> by_m;
    for (const auto& x : models) by_m.push_back(&x);
    std::stable_sort(by_m.begin(), by_m.end(), [](auto* a, auto* b) {
      return a->model.mixture.size() < b->model.mixture.size();
    });
    ChartSeries s;
    s.label = "models compared";
    s.markers = true;
    for (auto* x : by_m) s.points.push_back({double(x->model.mixture.size()), x->quality.psnr_db});
    ChartSeries base;
    base.label = "mean BRDF alone (M = 0)";
    base.colour = "#9ca3af";
    base.dashed = true;
    double max_m = 0;
    for (auto* x : by_m) max_m = std::max(max_m, double(x->model.mixture.size()));
    base.points = {{0.0, first.mean_brdf_only.psnr_db}, {max_m, first.mean_brdf_only.psnr_db}};
    c.series = {s, base};
    curves += svg_chart(c);
    Chart r;
    r.title = "PSNR against model size (rate-distortion)";
    r.x_label = "model size (KiB)";
    r.y_label = "PSNR (dB)";
    r.x_from_zero = true;
    ChartSeries t, counted;
    t.label = "models compared, file bytes";
    t.markers = true;
    t.colour = "#dc2626";
    counted.label = "models compared, paper's count";
    counted.markers = counted.hollow = true;
    counted.colour = "#dc2626";
    counted.dashed = true;
    std::vector<const ModelComparison*> by_bytes = by_m;
    std::stable_sort(by_bytes.begin(), by_bytes.end(),
                     [](auto* a, auto* b) { return a->file_bytes < b->file_bytes; });
    for (auto* x : by_bytes)
      if (x->file_bytes > 0)
        t.points.push_back({double(x->file_bytes) / 1024.0, x->quality.psnr_db});
    for (auto* x : by_m)
      counted.points.push_back({(double(x->model.mixture.size()) * kVariables * 2.0 * 4.0 +
                                 double(x->model.lights.size() * x->model.views.size()) * 3.0) /
                                    1024.0,
                                x->quality.psnr_db});
    r.series = {t, counted};
    curves += svg_chart(r);
  }
  curves += "</div>";
  if (models.size() == 1)
    curves +=
        "<p class=\"note\">One model: compare several models of this BTF (e.g. fitted with "
        "different M) in one command to trace the rate-distortion curves.</p>";
  curves += "</section>\n";

  if (models.size() > 1) h += curves;

  // One section per model: pictures, PSNR map, mean BRDF. The PSNR maps share one colour scale.
  std::array<double, 2> map_range{};
  bool have_range = false;
  for (const ModelComparison& c : models) {
    if (std::none_of(c.quality.images.begin(), c.quality.images.end(),
                     [](const ImageQuality& iq) { return std::isfinite(iq.psnr_db); }))
      continue;  // exact everywhere: no say in the scale
    const auto r = psnr_map_range(c.quality);
    map_range = have_range ? std::array<double, 2>{std::min(map_range[0], r[0]),
                                                   std::max(map_range[1], r[1])}
                           : r;
    have_range = true;
  }
  if (!have_range) map_range = {0.0, 1.0};
  for (std::size_t k = 0; k < models.size(); ++k) {
    const ModelComparison& c = models[k];
    const BtfModel& m = c.model;
    const BtfQuality& q = c.quality;
    const int w = m.width, hgt = m.height;
    const int f = upscale_for(std::max(w, hgt), 128);
    h += fmt::format(
        "<section><h2>{}: original | model | 10 &times; |difference|</h2>"
        "<div class=\"detail\"><div class=\"pairs\">",
        escape(c.name));
    std::vector<std::pair<std::size_t, std::size_t>> outline;
    for (const PicturedPair& p : c.pairs) {
      const std::string stem = fmt::format("m{}_l{}_v{}", k + 1, p.light, p.view);
      save_png(folder, stem + "_original.png",
               upscale_nearest(display_image(p.original, w, hgt, m.format, q.range), f));
      save_png(folder, stem + "_model.png",
               upscale_nearest(display_image(p.model, w, hgt, m.format, q.range), f));
      save_png(
          folder, stem + "_difference.png",
          upscale_nearest(difference_image(p.original, p.model, w, hgt, m.format, q.range), f));
      const ImageQuality& iq = q.images[p.light * q.views + p.view];
      if (p.label.find("worst") != std::string::npos) outline.push_back({p.light, p.view});
      h += "<figure><div class=\"imgs\">";
      for (const char* part : {"original", "model", "difference"})
        h += fmt::format(
            "<div><span>{}</span><img src=\"{}_{}.png\" width=\"{}\" height=\"{}\" "
            "alt=\"{}\"></div>",
            std::string(part) == "difference" ? "10 &times; |difference|" : part, stem, part, w * f,
            hgt * f, part);
      h += fmt::format(
          "</div><figcaption><b>{}</b>: light {}, view {}<br>RMSE {} &middot; PSNR {} dB "
          "&middot; SSIM {:.3f}</figcaption></figure>",
          escape(p.label), angles(m.lights[p.light]), angles(m.views[p.view]),
          rmse_text(iq.rmse, m.format), db(iq.psnr_db), iq.ssim);
    }
    const int largest = int(std::max(m.lights.size(), m.views.size()));
    const int cell = std::max(1, 250 / largest);
    h += fmt::format("</div><div class=\"maps\" style=\"width:{}px\">",
                     std::max(300, 46 + int(m.views.size()) * cell + 8 + 48 + 8));
    const auto [lo, hi] = map_range;
    const std::string map_png = fmt::format("m{}_psnr_map.png", k + 1);
    save_png(folder, map_png, upscale_nearest(psnr_map_image(q, lo, hi), cell));
    h += "<div><h3>PSNR of every (light, view) image</h3>";
    h += grid_svg(map_png, m.lights, m.views, cell, outline,
                  colour_bar(lo, hi, int(m.lights.size()) * cell, fmt::format("psnrbar{}", k + 1)),
                  48);
    h += "<p class=\"note\">Dark: the directions the model misses. Red squares: the worst images "
         "pictured.</p></div>";
    const bool new_tile = k == 0 || c.tile.x != first.tile.x || c.tile.y != first.tile.y ||
                          c.tile.width != first.tile.width || c.tile.height != first.tile.height;
    if (new_tile) {
      const std::string brdf_png = fmt::format("m{}_mean_brdf.png", k + 1);
      save_png(folder, brdf_png,
               upscale_nearest(
                   mean_brdf_image(c.mean_brdf, m.lights.size(), m.views.size(), m.format), cell));
      h += "<div><h3>Mean BRDF of the tile (the paper's Fig. 2)</h3>";
      h += grid_svg(brdf_png, m.lights, m.views, cell, {}, "", 0);
      h += fmt::format(
          "<p class=\"note\">Rows: lights, columns: views, each ring from &phi; = 0. "
          "Scaled so the brightest pair is white{}.</p></div>",
          hdr ? ", sRGB-encoded" : "");
    }
    h += "</div></div></section>\n";
  }

  if (models.size() == 1) h += curves;

  // How it is measured.
  const int window = first.quality.ssim_window;
  h += "<section class=\"notes\"><h2>How these numbers are measured</h2><ul>";
  h += fmt::format(
      "<li><b>RMSE</b> over all {} images, pixels and channels, {}; <b>PSNR</b> = "
      "20&nbsp;log<sub>10</sub>(R&nbsp;/&nbsp;RMSE) with R = {} of that RMSE.</li>",
      m0.lights.size() * m0.views.size(), hdr ? "in the data's units" : "on the 0-255 scale",
      hdr ? fmt::format("{:g} (the peak of the "
                        "original, HDR data)",
                        first.quality.range)
          : std::string("255"));
  h += fmt::format(
      "<li><b>SSIM</b> (Wang et al. 2004): {}&times;{} Gaussian window, &sigma; = 1.5, K1 = 0.01, "
      "K2 = 0.03, L = R, no padding; per channel, averaged over channels and images{}.</li>",
      window, window,
      window < 11 ? fmt::format(" (the tile is smaller than 11 pixels: the window shrinks to "
                                "{}&times;{}, the same Gaussian cut at its edge)",
                                window, window)
                  : std::string());
  h += "<li><b>Compression ratio</b>, the paper's count: W&middot;H&middot;ni&middot;nv&middot;3 "
       "bytes of 8-bit data against M&middot;9&middot;2 four-byte floats plus the mean BRDF as "
       "ni&middot;nv&middot;3 bytes; by the file: the same data against the bytes of the model "
       "file.</li>";
  h += "<li><b>Pictures</b>: the tile enlarged without smoothing; differences are "
       "10&nbsp;&times;&nbsp;|original&nbsp;&minus;&nbsp;model|, as in the paper's Fig. 3.</li>";
  h += "</ul></section>\n</main></body></html>\n";

  const fs::path index = folder / "index.html", tmp = folder / "index.html.tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    out << h;
    out.flush();
    if (!out)
      throw Error(Error::Kind::kIo, fmt::format("report: cannot write '{}'; check the free space "
                                                "and permissions",
                                                tmp.string()));
  }
  fs::rename(tmp, index, ec);
  if (ec)
    throw Error(Error::Kind::kIo, fmt::format("report: cannot rename '{}' to '{}': {}",
                                              tmp.string(), index.string(), ec.message()));
}

}  // namespace btfgmm
