// Text escaping and chart axes for the report's SVG; see svg.hpp.
#include "report/svg.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace btfgmm::svg {

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

Axis make_log_axis(double lo, double hi) {
  Axis a;
  a.log = true;
  if (!(lo > 0.0) || !std::isfinite(lo)) lo = 1.0;
  if (!(hi >= lo) || !std::isfinite(hi)) hi = lo;
  // A rounding margin, so that 100 computed as 99.99999 still sits on its decade.
  const double d0 = std::floor(std::log10(lo) + 1e-9), d1 = std::ceil(std::log10(hi) - 1e-9);
  a.lo = std::pow(10.0, d0);
  a.hi = std::pow(10.0, std::max(d1, d0 + 1.0));
  if (d1 - d0 <= 2.0) {  // a short range: from and to 1, 2 or 5 times a power of ten
    for (double m : {2.0, 5.0})
      if (m * std::pow(10.0, d0) <= lo * (1.0 + 1e-9)) a.lo = m * std::pow(10.0, d0);
    for (double m : {5.0, 2.0, 1.0})
      if (m * std::pow(10.0, d1 - 1.0) >= hi * (1.0 - 1e-9) && m * std::pow(10.0, d1 - 1.0) > a.lo)
        a.hi = m * std::pow(10.0, d1 - 1.0);
  }
  return a;
}

std::vector<double> axis_ticks(const Axis& a) {
  std::vector<double> ticks;
  if (!a.log) {
    for (double v = a.lo; v <= a.hi + a.step * 1e-6; v += a.step) ticks.push_back(v);
    return ticks;
  }
  const int d0 = int(std::floor(std::log10(a.lo) + 1e-9)),
            d1 = int(std::ceil(std::log10(a.hi) - 1e-9));
  if (d1 - d0 > 2) {  // decades only, at most about 8 of them labelled
    const int every = std::max(1, (d1 - d0 + 7) / 8);
    for (int d = d0; d <= d1; d += every) ticks.push_back(std::pow(10.0, d));
    return ticks;
  }
  for (int d = d0; d <= d1; ++d)
    for (double m : {1.0, 2.0, 5.0}) {
      const double v = m * std::pow(10.0, d);
      if (v >= a.lo * (1.0 - 1e-9) && v <= a.hi * (1.0 + 1e-9)) ticks.push_back(v);
    }
  return ticks;
}

std::string axis_tick_text(const Axis& a, double v) {
  return a.log ? fmt::format("{:g}", v) : tick_text(v, a.step);
}

}  // namespace btfgmm::svg
