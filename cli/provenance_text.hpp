// A model's provenance as the command shows it (info, fit --log): lines of text, JSON, and
// the iteration log written as a fit goes (JSON lines, or CSV).
#pragma once

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/measure/compare_data.hpp"
#include "btfgmm/model/provenance.hpp"
#include "cli_util.hpp"

namespace btfgmm::cli {

// One EM iteration of the log: `index` 0-based; `previous` the one before (for the relative
// gain, null for the first); `requested` the components the fit started with.
inline nlohmann::json iteration_json(std::size_t index, const btfgmm::IterationRecord& it,
                                     const btfgmm::IterationRecord* previous,
                                     std::size_t requested) {
  nlohmann::json j;
  j["iteration"] = index + 1;
  j["log_likelihood"] = it.log_likelihood;
  if (previous)
    j["relative_gain"] = (it.log_likelihood - previous->log_likelihood) /
                         std::max(std::abs(previous->log_likelihood), 1e-300);
  else
    j["relative_gain"] = nullptr;
  j["components"] = it.components;
  j["dropped"] = requested >= it.components ? requested - it.components : 0;
  j["seconds"] = it.seconds;
  return j;
}

inline nlohmann::json provenance_json(const btfgmm::Provenance& p, std::size_t requested) {
  if (!p.recorded) return nullptr;
  nlohmann::json j;
  const btfgmm::DataSource& s = p.data.source;
  j["source"] = s.name;
  j["image_size"] = {s.image_width, s.image_height};
  j["content_hash"] = btfgmm::hash_text(p.data.content_hash);
  nlohmann::json settings = nlohmann::json::object();
  for (const auto& [k, v] : p.fit.settings) settings[k] = v;
  j["settings"] = settings;
  j["fit_seconds"] = p.fit.seconds;
  j["runs"] = p.fit.runs;
  nlohmann::json its = nlohmann::json::array();
  for (std::size_t i = 0; i < p.fit.iterations.size(); ++i)
    its.push_back(
        iteration_json(i, p.fit.iterations[i], i ? &p.fit.iterations[i - 1] : nullptr, requested));
  j["iterations"] = its;
  return j;
}

// The lines `info` prints for a model's provenance.
inline void print_provenance_lines(const btfgmm::Provenance& p, const btfgmm::Tile& tile) {
  if (!p.recorded) {
    fmt::print(
        "  provenance   none recorded (written by an older btfgmm): the data it was "
        "fitted to cannot be checked\n");
    return;
  }
  fmt::print("  fitted to    {}\n", btfgmm::describe_source(p, tile));
  std::string settings;
  for (const auto& [k, v] : p.fit.settings)
    settings += fmt::format("{}{} {}", settings.empty() ? "" : ", ", k, v);
  fmt::print("  fit settings {}\n", settings);
  // Files written since fits became reproducible record no time (0): the same file at any load.
  const std::string runs =
      p.fit.runs > 1 ? fmt::format(" in {} runs (continued)", p.fit.runs) : std::string();
  if (p.fit.seconds > 0)
    fmt::print("  fit time     {}{}\n", btfgmm::human_seconds(p.fit.seconds), runs);
  else
    fmt::print("  fit time     not recorded (a model file is the same at any load){}\n", runs);
  const auto& its = p.fit.iterations;
  if (!its.empty())
    fmt::print(
        "  iterations   {} logged: L = {:.6f} at the first, {:.6f} at the last (info "
        "--json lists each)\n",
        its.size(), its.front().log_likelihood, its.back().log_likelihood);
}

// What `compare` and `render --compare` do with a check of the data against a model's
// provenance (measure/compare.hpp): nothing for the same data, a note where the model records
// none (unless `quiet`), and for other data an error, or with `force` a warning, `action`
// ("compare", "render") saying what goes on anyway.
inline btfgmm::DataMatch enforce_data_check(const btfgmm::DataCheck& c, bool force, bool quiet,
                                            const char* action) {
  if (c.match == btfgmm::DataMatch::kSame) return c.match;
  if (c.match == btfgmm::DataMatch::kNotRecorded) {
    if (!quiet) fmt::print(stderr, "note: {}\n", command_line_text(c.message));
    return c.match;
  }
  btfgmm::refuse_other_data(c, force, action);
  fmt::print(stderr, "warning: {}; going on with the {} (--force)\n", command_line_text(c.message),
             action);
  return c.match;
}

// `fit --log FILE`: a line per EM iteration as the fit goes, JSON (iteration_json) or, for a
// name ending in .csv, CSV with a header; written line by line and flushed, so the log of an
// interrupted fit holds every iteration run.
class IterationLog {
 public:
  IterationLog() = default;
  IterationLog(const std::string& path, std::size_t requested)
      : path_(path), requested_(requested), csv_(btfgmm::lower(path).ends_with(".csv")) {
    file_.reset(std::fopen(path.c_str(), "w"));
    if (!file_)
      throw Error(Error::Kind::kIo, fmt::format("--log: cannot write '{}' ({}); give a file in "
                                                "a folder you can write to",
                                                path, std::strerror(errno)));
    if (csv_) write("iteration,log_likelihood,relative_gain,components,dropped,seconds\n");
  }
  void add(const btfgmm::IterationRecord& it) {
    if (!file_) return;
    const nlohmann::json j = iteration_json(count_, it, count_ ? &previous_ : nullptr, requested_);
    previous_ = it;
    ++count_;
    if (!csv_) return write(j.dump() + "\n");
    write(fmt::format("{},{:.17g},{},{},{},{:.6f}\n", count_, it.log_likelihood,
                      j["relative_gain"].is_null()
                          ? std::string()
                          : fmt::format("{:.17g}", j["relative_gain"].get<double>()),
                      it.components, j["dropped"].get<std::size_t>(), it.seconds));
  }

 private:
  void write(const std::string& text) {
    if (std::fwrite(text.data(), 1, text.size(), file_.get()) != text.size() ||
        std::fflush(file_.get()) != 0)
      throw Error(Error::Kind::kIo, fmt::format("--log: cannot write '{}' ({}); check the disk",
                                                path_, std::strerror(errno)));
  }
  struct Close {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::string path_;
  std::size_t requested_ = 0, count_ = 0;
  bool csv_ = false;
  btfgmm::IterationRecord previous_;
  std::unique_ptr<std::FILE, Close> file_;
};

}  // namespace btfgmm::cli
