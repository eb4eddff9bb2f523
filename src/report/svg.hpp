// Pieces shared by the report's inline SVG and HTML: text escaping and chart axes with nice
// ticks.
#pragma once

#include <cstddef>
#include <string>

namespace btfgmm::svg {

// The colours of a chart's series, in order.
inline constexpr const char* kPalette[] = {"#2563eb", "#dc2626", "#16a34a", "#9333ea",
                                           "#ea580c", "#0891b2", "#be185d", "#4d7c0f"};
inline constexpr std::size_t kPaletteSize = sizeof(kPalette) / sizeof(kPalette[0]);

// `s` with &, <, > and " escaped for HTML text and attributes.
std::string escape(const std::string& s);

// A tick step of 1, 2, 2.5 or 5 times a power of ten giving about `target` ticks over `span`.
double nice_step(double span, int target);
// `v` with as many decimals as `step` needs.
std::string tick_text(double v, double step);

struct Axis {
  double lo = 0, hi = 1, step = 1;
};

// An axis over [lo, hi] (and 0 if `from_zero`) with a little room and about `ticks` nice ticks.
Axis make_axis(double lo, double hi, bool from_zero, int ticks);

}  // namespace btfgmm::svg
