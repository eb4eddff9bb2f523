// Numbers given as text (option values such as "30,45" or "0,0,25,25"), checked once with a
// message that names the option and shows the expected form.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/core/directions.hpp"

namespace btfgmm {

// A size in pixels: "N" (N x N) or "WxH", each 1..65536. Throws Error(kArgument) naming
// `option`.
std::pair<int, int> parse_size(const std::string& text, const std::string& option);

// Exactly `count` finite numbers separated by commas. Throws Error(kArgument) naming `option`
// and the value, with `example` showing the form (e.g. "30,45 (theta,phi in degrees)").
std::vector<double> parse_numbers(const std::string& text, const std::string& option,
                                  std::size_t count, const std::string& example);

// A direction on the upper hemisphere from THETA,PHI in degrees: theta in [0, 90], phi any
// finite angle, wrapped into [0, 360). Throws Error(kArgument) naming `option` and `text`
// (the value as given) for a theta off the hemisphere or a number that is not finite.
Direction hemisphere_direction(double theta, double phi, const std::string& option,
                               const std::string& text);
// "THETA,PHI" in degrees, as hemisphere_direction checks them.
Direction parse_direction(const std::string& text, const std::string& option);

}  // namespace btfgmm
