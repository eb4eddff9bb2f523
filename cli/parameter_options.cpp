// The fit's parameters as a command's options; see parameter_options.hpp.
#include "parameter_options.hpp"

#include <algorithm>
#include <variant>

namespace btfgmm::cli {
namespace {

// "a sentence" -> "A sentence".
std::string capitalised(std::string text) {
  if (!text.empty() && text[0] >= 'a' && text[0] <= 'z') text[0] = char(text[0] - 'a' + 'A');
  return text;
}

// How the help names a parameter's value: INT, FLOAT, the words it takes, TEXT.
std::string value_name(const btfgmm::FitParameter& p) {
  using T = btfgmm::ParameterType;
  if (p.type == T::kCount || p.type == T::kInteger) return "INT";
  if (p.type == T::kReal) return "FLOAT";
  if (p.type != T::kWord) return "TEXT";
  std::string words(p.choices);
  std::replace(words.begin(), words.end(), ' ', '|');
  return words;
}

// Whether some method takes `field` with `route`.
bool taken_with(std::string_view field, btfgmm::FitRoute route) {
  const btfgmm::FitParameter* p = btfgmm::route_parameter(field, route);
  return p && p->takes_route(route);
}

}  // namespace

std::map<std::string, std::string> given_options(const CLI::App& app) {
  std::map<std::string, std::string> given;
  for (const CLI::Option* opt : app.get_options())
    if (opt->count() > 0) {
      std::string names = opt->get_name(false, true);
      std::replace(names.begin(), names.end(), ',', '/');
      given[opt->get_name()] = names;
    }
  return given;
}

Error spelled_as_given(const Error& e, const std::map<std::string, std::string>& given) {
  return Error(e.kind(), btfgmm::spell_options(e.what(), [&](std::string_view field) {
                 const std::string flag = command_line_option(field);
                 const auto it = given.find(flag);
                 return it != given.end() ? it->second : flag;
               }));
}

void add_parameter_options(CLI::App& app, btfgmm::FitRoute route,
                           std::map<std::string, std::string>& texts,
                           const std::string& method_help) {
  for (const btfgmm::FitParameter* p : btfgmm::fit_parameters()) {
    if (std::holds_alternative<std::monostate>(p->member) || !taken_with(p->field, route)) continue;
    std::string flags = command_line_option(p->field);
    if (p->field == "components") flags += ",-M";
    const std::string help = p->field == "method" && !method_help.empty() ? method_help
                             : btfgmm::methods_taking(p->field).empty()  // a common one
                                 ? capitalised(command_line_text(btfgmm::parameter_help(p->field)))
                                 : command_line_text(btfgmm::parameter_help(p->field));
    app.add_option(flags, texts[std::string(p->field)], help)->type_name(value_name(*p));
  }
}

std::vector<std::string_view> read_parameters(const std::map<std::string, std::string>& given,
                                              const std::map<std::string, std::string>& texts,
                                              btfgmm::FitOptions& options, btfgmm::FitRoute route) {
  std::vector<std::string_view> fields;
  for (const btfgmm::FitParameter* p : btfgmm::fit_parameters()) {
    // The command's own options are the fit's job options for `fit` (route kNew), not `sweep`'s.
    const bool made_here = texts.count(std::string(p->field)) > 0;
    if (!given.count(command_line_option(p->field)) ||
        !(made_here || route == btfgmm::FitRoute::kNew))
      continue;
    fields.push_back(p->field);
    const auto text = texts.find(std::string(p->field));
    if (std::holds_alternative<std::monostate>(p->member) || text == texts.end()) continue;
    try {
      btfgmm::set_parameter(options, *p, btfgmm::parse_parameter(*p, text->second));
    } catch (const Error& e) {
      throw UsageError(e.kind(), spelled_as_given(e, given).what());
    }
  }
  return fields;
}

}  // namespace btfgmm::cli
