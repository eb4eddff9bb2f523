// Numbers given as text (option values such as "30,45" or "0,0,25,25"), checked once with a
// message that names the option and shows the expected form.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace btfgmm {

// Exactly `count` finite numbers separated by commas. Throws Error(kArgument) naming `option`
// and the value, with `example` showing the form (e.g. "30,45 (theta,phi in degrees)").
std::vector<double> parse_numbers(const std::string& text, const std::string& option,
                                  std::size_t count, const std::string& example);

}  // namespace btfgmm
