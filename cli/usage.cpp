// Usage help beyond CLI11's (usage.hpp).
#include "usage.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/text.hpp"

namespace btfgmm::cli {

void print_overview(const CLI::App& app) {
  fmt::print("{}\n", app.help());
}

namespace {

// The subcommand named `name`, or null.
const CLI::App* find_command(const CLI::App& app, std::string_view name) {
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    if (sub->get_name() == name) return sub;
  return nullptr;
}

std::string unknown_command(const CLI::App& app, std::string_view given) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    names.push_back(sub->get_name());
  const std::vector<std::string_view> views(names.begin(), names.end());
  return fmt::format("unknown command '{}'{}; the commands are: {} (btfgmm --help describes each)",
                     given, did_you_mean(given, views), fmt::join(names, ", "));
}

// "--name" for every long name of the command's options.
std::vector<std::string> long_options(const CLI::App& command) {
  std::vector<std::string> names;
  for (const CLI::Option* opt : command.get_options())
    for (const std::string& n : opt->get_lnames()) names.push_back("--" + n);
  return names;
}

}  // namespace

std::string mistyped_name(const CLI::App& app, int argc, const char* const* argv) {
  int at = 1;
  const std::vector<std::string> top = long_options(app);  // --help, --version
  const std::vector<std::string_view> top_views(top.begin(), top.end());
  for (; at < argc && argv[at][0] == '-'; ++at) {
    const std::string_view flag =
        std::string_view(argv[at]).substr(0, std::string_view(argv[at]).find('='));
    if (flag.size() > 2 && flag.substr(0, 2) == "--" &&
        std::find(top.begin(), top.end(), flag) == top.end())
      return fmt::format("unknown option '{}'{}; 'btfgmm --help' lists the options and commands",
                         flag, did_you_mean(flag, top_views));
  }
  if (at >= argc) return "";
  const CLI::App* command = find_command(app, argv[at]);
  if (!command) return unknown_command(app, argv[at]);
  const std::vector<std::string> names = long_options(*command);
  const std::vector<std::string_view> views(names.begin(), names.end());
  for (int i = at + 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg.size() < 3 || arg.substr(0, 2) != "--") continue;
    const std::string_view name = arg.substr(0, arg.find('='));
    bool known = false;
    for (const std::string& n : names) known = known || n == name;
    if (!known)
      return fmt::format("{}: unknown option '{}'{}; 'btfgmm {} --help' lists its options",
                         command->get_name(), name, did_you_mean(name, views), command->get_name());
  }
  return "";
}

// CLI11's range check reads "--components: Value 0 not in range 1 to 100000"; its parts, or
// nothing when the message is another. (Parsed by hand: GCC 12's std::regex trips
// -Wmaybe-uninitialized under the sanitizers.)
namespace {

struct RangeMessage {
  std::string option, value, low, high;
};

std::optional<RangeMessage> parse_range_message(const std::string& what) {
  const std::size_t colon = what.find(": Value ");
  const std::size_t range = what.rfind(" not in range ");
  if (colon == std::string::npos || range == std::string::npos || range < colon) return {};
  const std::size_t bounds = range + std::string_view(" not in range ").size();
  const std::size_t to = what.find(" to ", bounds);
  if (what.rfind("-", 0) != 0 || to == std::string::npos) return {};
  const std::size_t value = colon + std::string_view(": Value ").size();
  return RangeMessage{.option = what.substr(0, colon),
                      .value = what.substr(value, range - value),
                      .low = what.substr(bounds, to - bounds),
                      .high = what.substr(to + 4)};
}

}  // namespace

std::string out_of_range(const CLI::ParseError& err) {
  const std::optional<RangeMessage> m = parse_range_message(err.what());
  if (!m) return "";
  double number = 0;
  const char* end = m->value.data() + m->value.size();
  const auto parsed = std::from_chars(m->value.data(), end, number);
  const bool numeric = parsed.ec == std::errc() && parsed.ptr == end;
  const bool whole =
      m->low.find('.') == std::string::npos && m->high.find('.') == std::string::npos;
  return fmt::format("{} {}: {}; give {} from {} to {}", m->option, m->value,
                     numeric ? "out of range" : "not a number",
                     whole ? "a whole number" : "a number", m->low, m->high);
}

}  // namespace btfgmm::cli
