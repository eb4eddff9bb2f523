// The report's (light, view) grid pictures and colour bar as inline SVG; see grid.hpp.
#include "report/grid.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include "btfgmm/report/pictures.hpp"
#include "report/svg.hpp"

namespace btfgmm::svg {

namespace {

// Ticks at the first direction of each elevation ring of a set (the rows or columns of a
// (light, view) grid): index and theta.
std::vector<std::pair<std::size_t, double>> ring_starts(const DirectionSet& s) {
  std::vector<std::pair<std::size_t, double>> out;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (i == 0 || s[i].theta_deg != s[i - 1].theta_deg) out.push_back({i, s[i].theta_deg});
  return out;
}

// The marks along one axis of a grid, in pixels from its start.
struct AxisMarks {
  std::vector<double> ticks;
  std::vector<std::pair<double, std::string>> labels;
  bool rings = true;
};

// For sets of a few elevation rings (such as the 81 of UBO2003), a tick where each ring starts
// and its theta at the middle of its run (where two labels would collide, the later, larger
// ring keeps its own); for sets without rings (a spiral), every tenth or so index.
AxisMarks axis_marks(const DirectionSet& set, double gap, int cell) {
  AxisMarks m;
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
}

// The grid's frame and axis marks: views (columns) on top, lights (rows) on the left.
std::string grid_axes_svg(const DirectionSet& lights, const DirectionSet& views, int cell, int left,
                          int top) {
  const int gw = int(views.size()) * cell, gh = int(lights.size()) * cell;
  std::string s = fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" "
      "stroke=\"#9ca3af\"/>",
      left - 0.5, top - 0.5, gw + 1, gh + 1);
  const AxisMarks vm = axis_marks(views, 26, cell);
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
  const AxisMarks lm = axis_marks(lights, 12, cell);
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
  return s;
}

}  // namespace

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
  s += grid_axes_svg(lights, views, cell, left, top);
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
namespace {

// A vertical bar of the gradient `stops` (offset 0 at the bottom) from lo to hi, ticked.
std::string ticked_bar(double lo, double hi, int height, const std::string& id,
                       const std::string& unit,
                       const std::vector<std::pair<double, std::array<float, 3>>>& stops) {
  std::string s = "<defs><linearGradient id=\"" + id + "\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">";
  for (const auto& [t, c] : stops)
    s += fmt::format("<stop offset=\"{}\" stop-color=\"rgb({},{},{})\"/>", t, int(c[0]), int(c[1]),
                     int(c[2]));
  s += "</linearGradient></defs>";
  s += fmt::format(
      "<rect x=\"0\" y=\"0\" width=\"14\" height=\"{}\" fill=\"url(#{})\" "
      "stroke=\"#9ca3af\"/>",
      height, id);
  const Axis a = make_axis(lo, hi, false, 6);
  for (double v = a.lo; v <= hi + 1e-9; v += a.step) {
    if (v < lo - 1e-9) continue;
    const double y = height - (v - lo) / (hi - lo) * height;
    s += fmt::format(
        "<line x1=\"14\" x2=\"18\" y1=\"{0}\" y2=\"{0}\" stroke=\"#374151\"/>"
        "<text x=\"20\" y=\"{1}\" fill=\"#374151\">{2}</text>",
        y, y + 3.5, tick_text(v, a.step));
  }
  s += "<text x=\"0\" y=\"-8\" fill=\"#374151\">" + unit + "</text>";
  return s;
}

}  // namespace

std::string colour_bar(double lo_db, double hi_db, int height, const std::string& id) {
  std::vector<std::pair<double, std::array<float, 3>>> stops;
  for (int i = 0; i <= 8; ++i) stops.emplace_back(i / 8.0, colour_map(i / 8.0));
  return ticked_bar(lo_db, hi_db, height, id, "dB", stops);
}

std::string grey_bar(double lo, double hi, int height, const std::string& id,
                     const std::string& unit) {
  return ticked_bar(lo, hi > lo ? hi : lo + 1.0, height, id, unit,
                    {{0.0, {0, 0, 0}}, {1.0, {255, 255, 255}}});
}

}  // namespace btfgmm::svg
