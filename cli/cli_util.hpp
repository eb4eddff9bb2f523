// Small helpers shared by the btfgmm subcommands: parsing of angle pairs and sizes, output
// file and folder checks, JSON of direction sets and fit settings.
#pragma once

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/core/parse.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/measure/compare_data.hpp"
#include "btfgmm/model/model.hpp"

namespace btfgmm::cli {

// A value the command line gives that the library refuses as it reads it (a number out of its
// range, a word not among its choices): a usage error, exit status 2 as CLI11's own.
struct UsageError : Error {
  using Error::Error;
};

// The command's spelling of an option the library names by its field (core/text.hpp,
// option_name): "refine_steps" is --refine-steps.
inline std::string command_line_option(std::string_view field) {
  std::string flag = "--" + std::string(field);
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

// A library message as the command shows it: the options it names spelled as flags.
inline std::string command_line_text(std::string_view message) {
  return btfgmm::spell_options(message, command_line_option);
}

// That a file can be created in the folder `dir` (a probe file, removed at once), so a
// read-only file system or a folder such as /proc is reported before any work is done.
inline void check_writable_folder(const std::filesystem::path& dir,
                                  const std::filesystem::path& out) {
  const std::filesystem::path probe = dir / fmt::format(".btfgmm-probe-{}", ::getpid());
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int err = errno;
    if (err == EEXIST) return;  // another btfgmm of this id is probing: it is writable
    throw Error(Error::Kind::kIo,
                fmt::format("cannot write '{}': no file can be created in the folder '{}' ({}); "
                            "give an output path in a folder you can write to",
                            out.string(), dir.string(), std::strerror(err)));
  }
  ::close(fd);
  ::unlink(probe.c_str());
}

// An output folder may be new or empty; a non-empty one only with --overwrite.
inline void check_output_folder(const std::filesystem::path& out, bool overwrite) {
  std::error_code ec;
  if (std::filesystem::exists(out, ec) && !std::filesystem::is_directory(out, ec))
    throw Error(Error::Kind::kArgument,
                fmt::format("output '{}' exists and is not a folder; give a new folder name",
                            out.string()));
  // The folder itself, or the nearest folder above it that exists (it will be created there).
  std::filesystem::path dir = out;
  while (!dir.empty() && !std::filesystem::exists(dir, ec) && dir.has_parent_path() &&
         dir.parent_path() != dir)
    dir = dir.parent_path();
  if (dir.empty() || !std::filesystem::exists(dir, ec)) dir = ".";
  if (!std::filesystem::is_directory(dir, ec))
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot write the folder '{}': '{}' is a file, not a folder; give "
                            "an output path in a folder",
                            out.string(), dir.string()));
  check_writable_folder(dir, out);
  if (std::filesystem::is_directory(out, ec) && !std::filesystem::is_empty(out, ec) && !overwrite)
    throw Error(Error::Kind::kArgument,
                fmt::format("output folder '{}' is not empty; give a new folder or add "
                            "--overwrite to replace its images",
                            out.string()));
}

// A file to be written: its folder must exist; an existing file only with --overwrite.
// `text` written to `path` atomically (io/files.hpp); `what` names it in messages.
inline void write_text(const std::filesystem::path& path, const std::string& text,
                       const char* what) {
  btfgmm::write_file_atomically(
      path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), what);
}

inline void check_output_file(const std::filesystem::path& out, bool overwrite) {
  std::error_code ec;
  const auto dir = out.parent_path().empty() ? std::filesystem::path(".") : out.parent_path();
  if (!std::filesystem::is_directory(dir, ec))
    throw Error(Error::Kind::kArgument,
                std::filesystem::exists(dir, ec)
                    ? fmt::format("cannot write '{}': '{}' is a file, not a folder; give an "
                                  "output path in a folder",
                                  out.string(), dir.string())
                    : fmt::format("cannot write '{}': the folder '{}' does not exist; create it "
                                  "first",
                                  out.string(), dir.string()));
  if (std::filesystem::is_directory(out, ec))
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot write '{}': it is a folder; give a file name", out.string()));
  if (std::filesystem::exists(out, ec) && !overwrite)
    throw Error(
        Error::Kind::kArgument,
        fmt::format("'{}' exists; give a new name or add --overwrite to replace it", out.string()));
  check_writable_folder(dir, out);
}

// A fit's checkpoint is a file of its own: not the model the fit writes (which a finished fit
// would remove with it), nor its input.
inline void check_checkpoint_apart(const std::filesystem::path& checkpoint,
                                   const std::filesystem::path& model,
                                   const std::filesystem::path& input) {
  std::error_code ec;
  const auto same = [&](const std::filesystem::path& a, const std::filesystem::path& b) {
    return !b.empty() &&
           std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
  };
  for (const auto& [other, what] : {std::pair{&model, "model"}, std::pair{&input, "input"}})
    if (same(checkpoint, *other))
      throw Error(Error::Kind::kArgument,
                  fmt::format("--checkpoint '{}' is the fit's {}; give the checkpoint a name of "
                              "its own",
                              checkpoint.string(), what));
}

inline nlohmann::json set_json(const btfgmm::DirectionSet& s) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& d : s) a.push_back({d.theta_deg, d.phi_deg});
  return a;
}

// JSON indented by two spaces, with every array of numbers or strings on one line ("[30.0,
// 45.0]"): a list of direction pairs takes a line a pair, not four.
inline void put_json_text(std::string& out, const nlohmann::json& j, int depth) {
  if (!j.is_structured() || j.empty()) {
    out += j.dump();
    return;
  }
  if (j.is_array() &&
      std::none_of(j.begin(), j.end(), [](const nlohmann::json& e) { return e.is_structured(); })) {
    out += '[';
    for (std::size_t i = 0; i < j.size(); ++i) out += (i ? ", " : "") + j[i].dump();
    out += ']';
    return;
  }
  const std::string pad(std::size_t(2 * (depth + 1)), ' ');
  out += j.is_array() ? '[' : '{';
  for (auto it = j.begin(); it != j.end(); ++it) {
    out += (it == j.begin() ? "\n" : ",\n") + pad;
    if (j.is_object()) out += nlohmann::json(it.key()).dump() + ": ";
    put_json_text(out, *it, depth + 1);
  }
  out += '\n' + std::string(std::size_t(2 * depth), ' ') + (j.is_array() ? ']' : '}');
}

inline std::string json_text(const nlohmann::json& j) {
  std::string out;
  put_json_text(out, j, 0);
  return out + "\n";
}

// A path names a model file when it is a regular file that is neither a zip nor a Bonn .btf.
inline bool is_model_path(const std::filesystem::path& p) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(p, ec)) return false;
  return btfgmm::lower(p.extension().string()) != ".zip" && !btfgmm::is_ubo_btf_file(p);
}

// The lines `info` and `compare` print for a model's method, size and facts.
inline void print_model_lines(const btfgmm::Representation& r) {
  const btfgmm::MethodInfo& m = btfgmm::find_method(r.method());
  fmt::print("  method       {}: {} ({})\n", m.name, m.title, m.citation);
  fmt::print("  size         {}, {} values stored\n", r.size_text(), r.parameter_count());
  for (const auto& [k, v] : r.details()) fmt::print("  {:<12} {}\n", k, v);
}

}  // namespace btfgmm::cli
