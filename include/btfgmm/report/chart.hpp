// The report's curves as inline SVG: line and scatter charts, and the paper's Fig. 4 (the
// compression ratio against tile size) for the models compared. See docs/METRICS.md.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/measure/compare.hpp"

namespace btfgmm {

struct ChartSeries {
  std::string label;
  std::vector<std::array<double, 2>> points;  // (x, y)
  std::string colour = "#2563eb";
  bool line = true;      // join the points in order
  bool dashed = false;   // ... with a dashed line
  bool markers = false;  // a dot at every point
  bool hollow = false;   // ... hollow
  double width = 2.0;    // the line's width in pixels
};

struct Chart {
  std::string title, x_label, y_label;
  std::vector<ChartSeries> series;
  int width = 420, height = 300;
  bool x_from_zero = false, y_from_zero = false;
  bool x_integer = false;  // x takes whole numbers (e.g. M): ticks only at whole numbers
  bool x_log = false;      // a logarithmic x axis with decade ticks (points with x <= 0 left out)
};

// A line/scatter chart as an <svg> element (no xmlns, for inline HTML): nice ticks, axis
// labels, a legend. A chart with a log x axis says so: data-x-scale="log" on the element.
std::string svg_chart(const Chart& chart);

// The compression ratio against tile size (the paper's Fig. 4) for the direction sets of the
// models compared: a line per distinct M (and M = 600, the paper's setting), the models as
// points by the paper's count and by their file bytes.
Chart compression_ratio_chart(std::span<const ModelComparison> models);

// Rate-distortion: PSNR against the compression ratio of the model file (file bytes; log
// axis), one curve per method through its models in the order of their ratio, the same
// models by the paper's count as hollow markers, and the Pareto front over all models
// (measure/sweep.hpp: the highest PSNR at a ratio or any larger) as a wide grey step line
// behind the curves. Series: the front first (if any model has file bytes), then per method
// its curve (if any of its models has file bytes) and its paper's-count markers, then the
// legend's entry for the hollow markers.
Chart rate_distortion_chart(std::span<const ModelComparison> models);

}  // namespace btfgmm
