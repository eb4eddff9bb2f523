// Line and scatter charts as inline SVG, and the paper's Fig. 4; see chart.hpp.
#include "btfgmm/report/chart.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "btfgmm/core/error.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/model_file.hpp"
#include "report/svg.hpp"

namespace btfgmm {

namespace {

using svg::escape;
using svg::tick_text;

using svg::kPalette;
using svg::kPaletteSize;

// The plot area of a chart and its axes: data coordinates to pixels.
struct PlotArea {
  // Room for the tick labels (the last x tick's half, "10000", past the plot) and the labels.
  static constexpr int left = 66, right = 30, top = 30, bottom = 44;
  int pw = 0, ph = 0;  // the plot's width and height in pixels
  svg::Axis ax, ay;
  double px(double x) const {
    if (ax.log) return left + std::log10(x / ax.lo) / std::log10(ax.hi / ax.lo) * pw;
    return left + (x - ax.lo) / (ax.hi - ax.lo) * pw;
  }
  double py(double y) const { return top + ph - (y - ay.lo) / (ay.hi - ay.lo) * ph; }
  // A point the axes can show: finite, and x > 0 on a log axis.
  bool shows(const std::array<double, 2>& p) const {
    return std::isfinite(p[0]) && std::isfinite(p[1]) && (!ax.log || p[0] > 0.0);
  }
};

// Axes around the points of all series that the axes can show.
PlotArea plot_area(const Chart& chart) {
  PlotArea a;
  a.pw = chart.width - a.left - a.right;
  a.ph = chart.height - a.top - a.bottom;
  a.ax.log = chart.x_log;
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : chart.series)
    for (const auto& p : s.points) {
      if (!a.shows(p)) continue;
      x0 = std::min(x0, p[0]);
      x1 = std::max(x1, p[0]);
      y0 = std::min(y0, p[1]);
      y1 = std::max(y1, p[1]);
    }
  if (!std::isfinite(x0)) x0 = chart.x_log ? 1 : 0, x1 = chart.x_log ? 10 : 1, y0 = 0, y1 = 1;
  svg::Axis& ax = a.ax;
  if (chart.x_log) {
    ax = svg::make_log_axis(x0, x1);
  } else {
    ax = svg::make_axis(x0, x1, chart.x_from_zero, 5);
  }
  if (!chart.x_log && chart.x_integer && ax.step < 1.0) {  // no ticks between whole numbers
    ax.step = 1.0;
    ax.lo = std::floor(ax.lo);
    ax.hi = std::ceil(ax.hi);
  } else if (!chart.x_log && chart.x_integer && ax.step != std::floor(ax.step)) {
    ax.step = std::ceil(ax.step);
    ax.hi = ax.lo + std::ceil((ax.hi - ax.lo) / ax.step) * ax.step;
  }
  a.ay = svg::make_axis(y0, y1, chart.y_from_zero, 5);
  return a;
}

// The grid lines with their tick labels, the frame and the axis labels.
std::string axes_svg(const Chart& chart, const PlotArea& a) {
  const int left = a.left, top = a.top, pw = a.pw, ph = a.ph;
  std::string s;
  for (double v : svg::axis_ticks(a.ax)) {
    const double x = a.px(v);
    s += fmt::format(
        "<line x1=\"{0:.1f}\" x2=\"{0:.1f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#e5e7eb\"/>"
        "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\" fill=\"#4b5563\">{4}"
        "</text>",
        x, top, top + ph, top + ph + 14, svg::axis_tick_text(a.ax, v));
  }
  for (double v = a.ay.lo; v <= a.ay.hi + a.ay.step * 1e-6; v += a.ay.step) {
    const double y = a.py(v);
    s += fmt::format(
        "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.1f}\" y2=\"{2:.1f}\" stroke=\"#e5e7eb\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\" fill=\"#4b5563\">{5}</text>",
        left, left + pw, y, left - 5, y + 3.5, tick_text(v, a.ay.step));
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
  return s;
}

// Every series: its line through the finite points, and its markers.
std::string series_svg(const Chart& chart, const PlotArea& a) {
  std::string s = "<g>";
  for (const auto& series : chart.series) {
    std::string pts;
    for (const auto& p : series.points)
      if (a.shows(p)) pts += fmt::format("{:.1f},{:.1f} ", a.px(p[0]), a.py(p[1]));
    if (series.line && !pts.empty())
      s += fmt::format(
          "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{:g}\"{}/>", pts,
          series.colour, series.width, series.dashed ? " stroke-dasharray=\"6 4\"" : "");
    if (series.markers)
      for (const auto& p : series.points)
        if (a.shows(p))
          s += fmt::format(
              "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\" fill=\"{}\" stroke=\"{}\" "
              "stroke-width=\"1.5\"/>",
              a.px(p[0]), a.py(p[1]), series.hollow ? "#fff" : series.colour, series.colour);
  }
  s += "</g>";
  return s;
}

// The legend, below the axes: one row per labelled series.
std::string legend_svg(const Chart& chart) {
  std::string s;
  int row = 0;
  for (const auto& series : chart.series) {
    if (series.label.empty()) continue;
    const int y = chart.height + 12 + 15 * row++;
    const int x = PlotArea::left;
    if (series.line)
      s += fmt::format(
          "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2}\" y2=\"{2}\" stroke=\"{3}\" "
          "stroke-width=\"{4:g}\"{5}/>",
          x, x + 20, y - 3, series.colour, series.width,
          series.dashed ? " stroke-dasharray=\"6 4\"" : "");
    if (series.markers)
      s += fmt::format(
          "<circle cx=\"{}\" cy=\"{}\" r=\"4\" fill=\"{}\" stroke=\"{}\" "
          "stroke-width=\"1.5\"/>",
          x + 10, y - 3, series.hollow ? "#fff" : series.colour, series.colour);
    s += fmt::format("<text x=\"{}\" y=\"{}\" fill=\"#111827\">{}</text>", x + 26, y + 1,
                     escape(series.label));
  }
  return s;
}

}  // namespace

std::string svg_chart(const Chart& chart) {
  const PlotArea area = plot_area(chart);
  // The legend goes below the axes, one row per labelled series.
  const int rows = int(std::count_if(chart.series.begin(), chart.series.end(),
                                     [](const ChartSeries& c) { return !c.label.empty(); }));
  const int total_height = chart.height + 15 * rows + (rows ? 6 : 0);
  std::string s = fmt::format(
      "<svg class=\"chart\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"system-ui, sans-serif\" font-size=\"11\"{2}>",
      chart.width, total_height, chart.x_log ? " data-x-scale=\"log\"" : "");
  s += fmt::format(
      "<text x=\"{}\" y=\"16\" font-size=\"13\" font-weight=\"600\" "
      "fill=\"#111827\">{}</text>",
      PlotArea::left - 50, escape(chart.title));
  s += axes_svg(chart, area);
  s += series_svg(chart, area);
  s += legend_svg(chart);
  s += "</svg>";
  return s;
}

Chart compression_ratio_chart(std::span<const ModelComparison> models) {
  if (models.empty())
    throw Error(Error::Kind::kArgument, "compression ratio chart: give at least one model");
  const std::size_t ni = models[0].model->frame().lights.size(),
                    nv = models[0].model->frame().views.size();
  double max_pixels = 4096.0;  // the paper's 64 x 64 fit
  std::set<std::size_t> ms{600};
  for (const auto& m : models) {
    max_pixels = std::max(max_pixels, 1.25 * double(m.model->frame().pixels()));
    if (m.model->method() == kMixtureMethod) ms.insert(std::size_t(m.model->size_order()));
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
    const bool used = std::any_of(models.begin(), models.end(), [&](const auto& x) {
      return x.model->method() == kMixtureMethod && std::size_t(x.model->size_order()) == m;
    });
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
    const double px = double(m.model->frame().pixels());
    paper.points.push_back({px, m.model->paper_ratio()});
    if (m.file_bytes > 0) file.points.push_back({px, m.model->file_ratio(m.file_bytes)});
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

namespace {

// The methods of the models, in the order they first appear.
std::vector<std::string> methods_of(std::span<const ModelComparison> models) {
  std::vector<std::string> methods;
  for (const auto& x : models)
    if (std::find(methods.begin(), methods.end(), x.model->method()) == methods.end())
      methods.emplace_back(x.model->method());
  return methods;
}

// A method's colour: its place among all methods (methods/registry.hpp), so that every method
// has its own and keeps it from chart to chart.
const char* method_colour(std::string_view method, std::size_t fallback) {
  const std::span<const MethodInfo> all = all_methods();
  for (std::size_t k = 0; k < all.size(); ++k)
    if (all[k].name == method) return svg::kPalette[k % svg::kPaletteSize];
  return svg::kPalette[fallback % svg::kPaletteSize];
}

// The Pareto front as a step line: f(r) = the highest PSNR at a ratio of r or more, from the
// front's lowest ratio to its highest (each step drops at the ratio of a model on the front).
ChartSeries pareto_steps(std::span<const ModelComparison> models) {
  const std::vector<bool> front = pareto_front(models);
  std::vector<std::array<double, 2>> points;
  for (std::size_t i = 0; i < models.size(); ++i)
    if (front[i])
      points.push_back(
          {models[i].model->file_ratio(models[i].file_bytes), models[i].quality.psnr_db});
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) {
    return a[0] < b[0] || (a[0] == b[0] && a[1] > b[1]);
  });
  ChartSeries s;
  s.label = "Pareto front: the highest PSNR at this ratio or more";
  s.colour = "#d1d5db";
  s.width = 7.0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (k > 0) s.points.push_back({points[k - 1][0], points[k][1]});
    s.points.push_back(points[k]);
  }
  return s;
}

}  // namespace

Chart rate_distortion_chart(std::span<const ModelComparison> models) {
  Chart r;
  r.title = "PSNR against compression ratio (rate-distortion)";
  r.x_label = "compression ratio 1:x of the model file (log scale)";
  r.y_label = "PSNR (dB)";
  r.x_log = true;
  r.width = 560;
  r.height = 340;
  const bool any_file = std::any_of(models.begin(), models.end(),
                                    [](const ModelComparison& x) { return x.file_bytes > 0; });
  if (any_file) r.series.push_back(pareto_steps(models));
  const std::vector<std::string> methods = methods_of(models);
  for (std::size_t k = 0; k < methods.size(); ++k) {
    ChartSeries file, counted;
    file.markers = counted.markers = counted.hollow = true;
    counted.line = false;
    file.colour = counted.colour = method_colour(methods[k], k);
    std::vector<const ModelComparison*> own;
    for (const auto& x : models)
      if (x.model->method() == methods[k]) own.push_back(&x);
    // A synthesis: shown, dashed, its pixel-wise PSNR marked as measuring nothing (it is not
    // on the front).
    const bool synthesis = own.front()->model->synthesises();
    file.label =
        synthesis ? methods[k] + " (synthesis: new texture, its PSNR not meaningful)" : methods[k];
    file.dashed = synthesis;
    for (const ModelComparison* x : own)
      counted.points.push_back({x->model->paper_ratio(), x->quality.psnr_db});
    std::stable_sort(own.begin(), own.end(), [](auto* a, auto* b) {
      return a->model->file_ratio(a->file_bytes) < b->model->file_ratio(b->file_bytes);
    });
    for (const ModelComparison* x : own)
      if (x->file_bytes > 0)
        file.points.push_back({x->model->file_ratio(x->file_bytes), x->quality.psnr_db});
    if (!file.points.empty()) r.series.push_back(file);
    if (file.points.empty()) counted.label = methods[k] + ", paper's count";
    r.series.push_back(counted);
  }
  ChartSeries hollow;  // the legend's entry for every method's hollow markers
  hollow.label = "hollow: the same models by the paper's count (Table 2)";
  hollow.colour = "#6b7280";
  hollow.line = false;
  hollow.markers = hollow.hollow = true;
  r.series.push_back(hollow);
  return r;
}

}  // namespace btfgmm
