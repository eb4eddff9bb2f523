// Pieces shared by the report's inline SVG and HTML: text escaping and chart axes with nice
// ticks.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace btfgmm::svg {

// The colours of a chart's series, in order.
inline constexpr const char* kPalette[] = {"#2563eb", "#dc2626", "#16a34a", "#9333ea", "#ea580c",
                                           "#0891b2", "#be185d", "#4d7c0f", "#a16207", "#475569"};
inline constexpr std::size_t kPaletteSize = sizeof(kPalette) / sizeof(kPalette[0]);

// `s` with &, <, > and " escaped for HTML text and attributes.
std::string escape(const std::string& s);

// A tick step of 1, 2, 2.5 or 5 times a power of ten giving about `target` ticks over `span`.
double nice_step(double span, int target);
// `v` with as many decimals as `step` needs.
std::string tick_text(double v, double step);

struct Axis {
  double lo = 0, hi = 1, step = 1;
  bool log = false;  // logarithmic: lo and hi are powers of ten, `step` is unused
};

// An axis over [lo, hi] (and 0 if `from_zero`) with a little room and about `ticks` nice ticks.
Axis make_axis(double lo, double hi, bool from_zero, int ticks);
// A logarithmic axis over [lo, hi] (both > 0): from the power of ten at or below lo to the one
// at or above hi (at least one decade); over at most two decades, from and to the nearest 1,
// 2 or 5 times a power of ten instead (7 to 22: 5 to 50).
Axis make_log_axis(double lo, double hi);
// The axis's tick values, from lo to hi: every step; on a log axis every decade (every second
// or more over more than 8 decades), and over at most two decades 1, 2 and 5 times each.
std::vector<double> axis_ticks(const Axis& a);
// A tick's label: tick_text on a linear axis; on a log axis "0.01", "5", "1000", "1e+06".
std::string axis_tick_text(const Axis& a, double v);

}  // namespace btfgmm::svg
