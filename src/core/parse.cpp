#include "btfgmm/core/parse.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>

#include "btfgmm/core/error.hpp"

namespace btfgmm {

std::vector<double> parse_numbers(const std::string& text, const std::string& option,
                                  std::size_t count, const std::string& example) {
  std::vector<double> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    double v = 0;
    const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
    if (item.empty() || r.ec != std::errc() || r.ptr != item.data() + item.size() ||
        !std::isfinite(v))
      throw Error(Error::Kind::kArgument,
                  fmt::format("{} '{}': '{}' is not a finite number; write it like {}", option,
                              text, item, example));
    out.push_back(v);
    start = comma + 1;
  }
  if (out.size() != count)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} '{}' needs {} numbers separated by commas, like {}", option, text,
                            count, example));
  return out;
}

}  // namespace btfgmm
