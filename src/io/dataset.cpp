// BTF data sets on disk: UTIA folders (nested or flat), Bonn folders and Bonn zips (read in
// place with libzip), and the UTIA writer.
#include "btfgmm/io/dataset.hpp"

#include <fmt/format.h>
#include <zip.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <system_error>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

constexpr const char* kExpectedNames =
    "expected tlTTT_plPPP_tvTTT_pvPPP.png (UTIA) or 'NNNNN tlTTT plPPP tvTTT pvPPP.jpg' (Bonn)";

bool is_digit(char c) {
  return c >= '0' && c <= '9';
}

std::vector<std::string> split_tokens(const std::string& s) {
  std::vector<std::string> tokens;
  std::string cur;
  for (char c : s) {
    if (c == '_' || c == ' ') {
      if (!cur.empty()) tokens.push_back(std::move(cur));
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) tokens.push_back(std::move(cur));
  return tokens;
}

// "023.5" -> 23.5: digits with an optional fraction, nothing else.
std::optional<double> parse_number(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size() && is_digit(s[i])) ++i;
  if (i == 0) return std::nullopt;
  if (i < s.size()) {
    if (s[i] != '.') return std::nullopt;
    std::size_t j = i + 1;
    while (j < s.size() && is_digit(s[j])) ++j;
    if (j == i + 1 || j != s.size()) return std::nullopt;
  }
  double v = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::fixed);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// "tl023.5" with prefix "tl" -> 23.5.
std::optional<double> parse_angle_token(const std::string& token, const char* prefix) {
  if (token.size() < 3 || lower(token.substr(0, 2)) != prefix) return std::nullopt;
  return parse_number(token.substr(2));
}

// An angle as it appears in a UTIA name: 3 integer digits, then the shortest fraction (at
// most 3 decimals) that reads back as the same double.
std::string format_angle(double a) {
  if (a == std::floor(a) && std::fabs(a) < 1e9)
    return fmt::format("{:03d}", static_cast<long long>(a));
  std::string best;
  for (int k = 1; k <= 3; ++k) {
    std::string s = fmt::format("{:0{}.{}f}", a, 4 + k, k);
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    best = s;
    double back = 0.0;
    std::from_chars(s.data(), s.data() + s.size(), back);
    if (back == a) break;
  }
  return best;
}

std::string angles(const Direction& d, const char* t, const char* p, char sep) {
  return fmt::format("{}{}{}{}{}", t, format_angle(d.theta_deg), sep, p, format_angle(d.phi_deg));
}

// A folder named after a view: tv030_pv060 (or with a space); the view it names.
std::optional<Direction> parse_view_folder(const std::string& folder) {
  const auto tokens = split_tokens(folder);
  if (tokens.size() != 2) return std::nullopt;
  const auto tv = parse_angle_token(tokens[0], "tv");
  const auto pv = parse_angle_token(tokens[1], "pv");
  if (!tv || !pv) return std::nullopt;
  return Direction{*tv, *pv};
}

bool macos_junk(const std::string& rel) {
  const std::string file = rel.substr(rel.rfind('/') + 1);
  return rel.rfind("__MACOSX/", 0) == 0 || rel.find("/__MACOSX/") != std::string::npos ||
         file.rfind("._", 0) == 0;
}

bool is_zip_name(const fs::path& p) {
  return lower(p.extension().string()) == ".zip";
}

// The first exception of a parallel loop by loop index, so the error reported does not
// depend on thread timing. Work past the first failure is skipped.
class FirstError {
 public:
  void capture(std::size_t i) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (i < index_.load()) {
      index_ = i;
      error_ = std::current_exception();
    }
  }
  bool skip(std::size_t i) const { return i > index_.load(); }
  void rethrow() const {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  std::mutex mutex_;
  std::atomic<std::size_t> index_{std::numeric_limits<std::size_t>::max()};
  std::exception_ptr error_;
};

// ---- zip -----------------------------------------------------------------------------

struct ZipCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};
using Zip = std::unique_ptr<zip_t, ZipCloser>;

Zip open_zip(const fs::path& path) {
  int code = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!z) {
    zip_error_t err;
    zip_error_init_with_code(&err, code);
    const std::string reason = zip_error_strerror(&err);
    zip_error_fini(&err);
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is not a readable zip archive (libzip: {}); give a Bonn "
                            "material .zip as downloaded, or a folder of images",
                            path.string(), reason));
  }
  return Zip(z);
}

std::string entry_display(const fs::path& zip, const std::string& entry) {
  return fmt::format("{}:{}", zip.string(), entry);
}

std::vector<std::uint8_t> read_zip_entry(zip_t* z, const fs::path& zip, const std::string& entry) {
  const zip_int64_t index = zip_name_locate(z, entry.c_str(), 0);
  zip_stat_t st;
  zip_stat_init(&st);
  if (index < 0 || zip_stat_index(z, zip_uint64_t(index), 0, &st) != 0)
    throw Error(Error::Kind::kIo, fmt::format("cannot read {}: entry not found ({})",
                                              entry_display(zip, entry), zip_strerror(z)));
  if (st.size > (zip_uint64_t(1) << 31))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} is {} bytes uncompressed, too large for a BTF image",
                            entry_display(zip, entry), st.size));
  // What the entry's stored bytes can hold: deflate expands at most 1032 times, a stored
  // entry not at all. (Other methods are bounded by the check above and the memory's.)
  if ((st.valid & ZIP_STAT_COMP_SIZE) && (st.valid & ZIP_STAT_COMP_METHOD) &&
      ((st.comp_method == ZIP_CM_STORE && st.size > st.comp_size) ||
       (st.comp_method == ZIP_CM_DEFLATE &&
        double(st.size) > limits::kDeflateMaxRatio * double(st.comp_size) + 1032.0)))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} claims {} bytes uncompressed from {} stored bytes, more than "
                            "they can hold; the archive is corrupt, download it again",
                            entry_display(zip, entry), st.size, st.comp_size));
  limits::check_memory(
      double(st.size), fmt::format("reading {} ({} bytes)", entry_display(zip, entry), st.size),
      "the archive is corrupt, or the entry too large for this machine", Error::Kind::kFormat);
  zip_file_t* f = zip_fopen_index(z, zip_uint64_t(index), 0);
  if (!f)
    throw Error(Error::Kind::kIo, fmt::format("cannot read {}: libzip: {}",
                                              entry_display(zip, entry), zip_strerror(z)));
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(st.size));
  const zip_int64_t n = zip_fread(f, bytes.data(), bytes.size());
  std::string reason = n < 0 ? zip_error_strerror(zip_file_get_error(f)) : "";
  zip_fclose(f);
  if (n < 0 || zip_uint64_t(n) != st.size)
    throw Error(Error::Kind::kFormat,
                fmt::format("cannot read {}: {}; the archive is corrupt or truncated, "
                            "download it again",
                            entry_display(zip, entry),
                            n < 0 ? "libzip: " + reason : "the entry ended early"));
  return bytes;
}

std::vector<std::uint8_t> read_file(const fs::path& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), std::fclose);
  const auto fail = [&](int err) {
    return Error(Error::Kind::kIo, fmt::format("cannot read {}: {}", path.string(),
                                               err ? std::strerror(err) : "it ended early"));
  };
  if (!f) throw fail(errno);
  // The file's size, checked before reading it whole.
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec)
    limits::check_memory(double(size), fmt::format("reading {} ({} bytes)", path.string(), size),
                         "it is not a BTF image; move it out of the folder", Error::Kind::kIo);
  std::vector<std::uint8_t> bytes;
  std::size_t used = 0;
  for (;;) {
    bytes.resize(std::max<std::size_t>(used * 2, 1 << 16));
    const std::size_t n = std::fread(bytes.data() + used, 1, bytes.size() - used, f.get());
    used += n;
    if (used < bytes.size()) break;
  }
  bytes.resize(used);
  if (std::ferror(f.get())) throw fail(errno);
  return bytes;
}

// ---- discovery ---------------------------------------------------------------------------

struct Found {
  std::string rel;      // relative path or zip entry name
  std::string display;  // for messages: full path, or zip:entry
  ParsedName name;
  ImageFormat format;
  bool in_view_folder = false;
  std::uint64_t bytes = 0;
};

using Angles = std::pair<double, double>;

Angles key(const Direction& d) {
  return {d.theta_deg, d.phi_deg};
}

// Run body(i) for i in [0, n) in parallel; body may throw. The first error (by index) is
// rethrown after the loop. make_state() builds a per-thread state (e.g. a zip handle)
// passed to body.
template <class State, class MakeState, class Body>
void parallel_each(std::size_t n, MakeState make_state, Body body) {
  FirstError first;
  const auto count = static_cast<std::int64_t>(n);
#pragma omp parallel
  {
    std::optional<State> state;
    try {
      state.emplace(make_state());
    } catch (...) {
      first.capture(0);
    }
#pragma omp for schedule(dynamic)
    for (std::int64_t i = 0; i < count; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (!state || first.skip(u)) continue;
      try {
        body(*state, u);
      } catch (...) {
        first.capture(u);
      }
    }
  }
  first.rethrow();
}

struct NoState {};

}  // namespace

std::string to_string(Layout l) {
  switch (l) {
    case Layout::kUtiaNested:
      return "UTIA (one folder per view)";
    case Layout::kUtiaFlat:
      return "UTIA (flat folder)";
    case Layout::kBonnFolder:
      return "Bonn (folder)";
    case Layout::kBonnZip:
      return "Bonn (zip)";
  }
  return "?";
}

ParsedName parse_image_name(const std::string& file_name) {
  const std::string file = file_name.substr(file_name.find_last_of('/') + 1);
  // The stem: drop an extension made of letters (not the fraction of "pv022.5").
  std::string stem = file;
  if (const auto dot = file.rfind('.'); dot != std::string::npos) {
    const std::string ext = file.substr(dot + 1);
    if (!ext.empty() && std::all_of(ext.begin(), ext.end(), [](char c) {
          return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
        }))
      stem = file.substr(0, dot);
  }
  const auto bad = [&]() {
    return Error(Error::Kind::kFormat,
                 fmt::format("'{}' is not a BTF image name: {}", file, kExpectedNames));
  };
  auto tokens = split_tokens(stem);
  ParsedName out;
  if (!tokens.empty() && std::all_of(tokens[0].begin(), tokens[0].end(), is_digit)) {
    long index = 0;
    const auto& t = tokens[0];
    const auto r = std::from_chars(t.data(), t.data() + t.size(), index);
    if (r.ec != std::errc()) throw bad();
    out.index = index;
    tokens.erase(tokens.begin());
  }
  if (tokens.size() != 4) throw bad();
  const auto tl = parse_angle_token(tokens[0], "tl");
  const auto pl = parse_angle_token(tokens[1], "pl");
  const auto tv = parse_angle_token(tokens[2], "tv");
  const auto pv = parse_angle_token(tokens[3], "pv");
  if (!tl || !pl || !tv || !pv) throw bad();
  const auto check = [&](double v, const char* what, bool theta) {
    if (theta ? (v < 0.0 || v > 90.0) : (v < 0.0 || v >= 360.0))
      throw Error(Error::Kind::kFormat,
                  fmt::format("'{}': {} angle {} is outside {}; elevations (tl, tv) lie in "
                              "[0, 90] degrees and azimuths (pl, pv) in [0, 360)",
                              file, what, v, theta ? "[0, 90]" : "[0, 360)"));
  };
  check(*tl, "tl (light elevation)", true);
  check(*pl, "pl (light azimuth)", false);
  check(*tv, "tv (view elevation)", true);
  check(*pv, "pv (view azimuth)", false);
  out.light = {*tl, *pl};
  out.view = {*tv, *pv};
  return out;
}

std::string utia_image_stem(const Direction& light, const Direction& view) {
  return angles(light, "tl", "pl", '_') + "_" + angles(view, "tv", "pv", '_');
}

const std::string& BtfSource::image_name(std::size_t light, std::size_t view) const {
  return names_.at(light * info_.views.size() + view);
}

BtfSource BtfSource::open(const fs::path& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status))
    throw Error(
        Error::Kind::kIo,
        fmt::format(
            "{} does not exist{}; give a folder of BTF images or a Bonn .zip", path.string(),
            ec && ec != std::errc::no_such_file_or_directory ? " (" + ec.message() + ")" : ""));
  const bool zip = fs::is_regular_file(status);
  if (zip && !is_zip_name(path))
    throw Error(Error::Kind::kArgument,
                fmt::format("{} is a file; give a folder of BTF images or a Bonn .zip archive",
                            path.string()));
  if (!zip && !fs::is_directory(status))
    throw Error(Error::Kind::kArgument,
                fmt::format("{} is neither a folder nor a .zip archive", path.string()));

  BtfSource src;
  BtfInfo& info = src.info_;
  info.path = path;

  // 1. The candidate files: relative names, sorted, with their stored sizes.
  std::vector<std::pair<std::string, std::uint64_t>> files;
  if (zip) {
    Zip z = open_zip(path);
    const zip_int64_t n = zip_get_num_entries(z.get(), 0);
    // Every entry has a central directory record of at least 46 bytes.
    std::error_code size_ec;
    const std::uintmax_t zip_bytes = fs::file_size(path, size_ec);
    if (n < 0 || (!size_ec && std::uintmax_t(n) > zip_bytes / 46))
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} claims {} entries, more than its {} bytes can hold; the "
                              "archive is corrupt, download it again",
                              path.string(), n, zip_bytes));
    for (zip_int64_t i = 0; i < n; ++i) {
      zip_stat_t st;
      zip_stat_init(&st);
      if (zip_stat_index(z.get(), zip_uint64_t(i), 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME))
        throw Error(Error::Kind::kFormat,
                    fmt::format("{}: cannot read entry {} (libzip: {}); the archive is "
                                "corrupt, download it again",
                                path.string(), i, zip_strerror(z.get())));
      const std::string name = st.name;
      if (!name.empty() && name.back() == '/') continue;  // a folder
      files.emplace_back(name, (st.valid & ZIP_STAT_COMP_SIZE) ? st.comp_size : 0);
    }
  } else {
    try {
      for (auto it = fs::recursive_directory_iterator(
               path, fs::directory_options::follow_directory_symlink);
           it != fs::recursive_directory_iterator(); ++it) {
        if (!it->is_regular_file()) continue;
        files.emplace_back(fs::relative(it->path(), path).generic_string(), it->file_size());
      }
    } catch (const fs::filesystem_error& e) {
      throw Error(Error::Kind::kIo,
                  fmt::format("cannot list the folder {}: {}", path.string(), e.code().message()));
    }
  }
  std::sort(files.begin(), files.end());

  // 2. Parse the image names.
  std::vector<Found> found;
  for (const auto& [rel, bytes] : files) {
    const std::string display = zip ? entry_display(path, rel) : (path / rel).string();
    const std::string file = rel.substr(rel.find_last_of('/') + 1);
    if (macos_junk(rel) || !image_format_from_name(file)) {
      ++info.ignored_files;
      continue;
    }
    Found f;
    f.rel = rel;
    f.display = display;
    f.format = *image_format_from_name(file);
    f.bytes = bytes;
    try {
      f.name = parse_image_name(file);
    } catch (const Error& e) {
      throw Error(Error::Kind::kFormat, fmt::format("{}: {}; rename the file or move it out of {}",
                                                    display, e.what(), path.string()));
    }
    const auto slash = rel.find_last_of('/');
    if (slash != std::string::npos) {
      const std::string dir = rel.substr(0, slash);
      const std::string folder = dir.substr(dir.find_last_of('/') + 1);
      if (const auto v = parse_view_folder(folder)) {
        if (v->theta_deg != f.name.view.theta_deg || v->phi_deg != f.name.view.phi_deg)
          throw Error(Error::Kind::kFormat,
                      fmt::format("{} lies in the view folder {} but its name says view {}; "
                                  "move it to a folder {} or rename it",
                                  display, folder, angles(f.name.view, "tv", "pv", ' '),
                                  angles(f.name.view, "tv", "pv", '_')));
        f.in_view_folder = true;
      }
    }
    found.push_back(std::move(f));
  }
  if (found.empty())
    throw Error(Error::Kind::kFormat,
                fmt::format("no BTF images found in {}{}; expected images named like "
                            "tv000_pv000/tl000_pl000_tv000_pv000.png (UTIA) or "
                            "'00008 tl000 pl000 tv030 pv030.jpg' (Bonn), or a Bonn .zip",
                            path.string(),
                            info.ignored_files
                                ? fmt::format(" ({} non-image file{} ignored)", info.ignored_files,
                                              info.ignored_files == 1 ? "" : "s")
                                : ""));

  // 3. Layout and direction sets.
  const bool indexed = std::any_of(found.begin(), found.end(),
                                   [](const Found& f) { return f.name.index.has_value(); });
  const bool nested =
      std::any_of(found.begin(), found.end(), [](const Found& f) { return f.in_view_folder; });
  info.layout = zip       ? Layout::kBonnZip
                : indexed ? Layout::kBonnFolder
                : nested  ? Layout::kUtiaNested
                          : Layout::kUtiaFlat;
  std::map<Angles, std::size_t> light_index, view_index;
  for (const Found& f : found) {
    light_index.emplace(key(f.name.light), 0);
    view_index.emplace(key(f.name.view), 0);
  }
  std::vector<Direction> lights, views;
  for (auto& [a, i] : light_index) {
    i = lights.size();
    lights.push_back({a.first, a.second});
  }
  for (auto& [a, i] : view_index) {
    i = views.size();
    views.push_back({a.first, a.second});
  }
  info.lights = DirectionSet(lights);
  info.views = DirectionSet(views);

  // 4. One image per pair. The pairs found are indexed first (nl x nv may be far more than
  // the files: a table of every pair is only made once each has its image).
  const std::size_t nl = lights.size(), nv = views.size();
  std::map<std::size_t, const Found*> present;
  for (const Found& f : found) {
    const std::size_t i = light_index.at(key(f.name.light)) * nv + view_index.at(key(f.name.view));
    const auto [at, fresh] = present.emplace(i, &f);
    if (!fresh)
      throw Error(
          Error::Kind::kFormat,
          fmt::format("two images for light {} and view {}: {} and {}; keep one and "
                      "remove the other",
                      angles(f.name.light, "tl", "pl", ' '), angles(f.name.view, "tv", "pv", ' '),
                      at->second->display, f.display));
  }
  std::vector<std::string> missing;
  const std::size_t n_missing = nl * nv - present.size();
  const std::string ext = fs::path(found.front().rel).extension().string();
  // The first five missing pairs lie within the first present.size() + 5 indices.
  for (std::size_t i = 0; i < nl * nv && missing.size() < 5 && n_missing > 0; ++i) {
    if (present.count(i)) continue;
    const std::size_t l = i / nv, v = i % nv;
    const std::string stem = utia_image_stem(lights[l], views[v]);
    switch (info.layout) {
      case Layout::kUtiaNested:
        missing.push_back(angles(views[v], "tv", "pv", '_') + "/" + stem + ext);
        break;
      case Layout::kUtiaFlat:
        missing.push_back(stem + ext);
        break;
      default:
        missing.push_back(fmt::format("'NNNNN {} {}{}'", angles(lights[l], "tl", "pl", ' '),
                                      angles(views[v], "tv", "pv", ' '), ext));
    }
  }
  if (n_missing)
    throw Error(Error::Kind::kFormat,
                fmt::format("{}: {} of the {} images ({} lights x {} views, the directions "
                            "found in the names) are missing: {}{}; every (light, view) pair "
                            "needs exactly one image",
                            path.string(), n_missing, nl * nv, nl, nv, fmt::join(missing, ", "),
                            n_missing > missing.size() ? ", ..." : ""));
  for (const Found& f : found)
    if (f.format != found.front().format)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} mixes image formats: {} and {}; convert all images to one "
                              "format",
                              path.string(), found.front().display, f.display));
  info.image_format = found.front().format;

  std::vector<const Found*> by_pair(nl * nv, nullptr);
  for (const auto& [i, f] : present) by_pair[i] = f;
  src.names_.resize(nl * nv);
  std::vector<std::string> displays(nl * nv);
  for (std::size_t i = 0; i < by_pair.size(); ++i) {
    src.names_[i] = by_pair[i]->rel;
    displays[i] = by_pair[i]->display;
    info.file_bytes += by_pair[i]->bytes;
  }

  // 5. Headers: one size and one sample format.
  std::vector<ImageHeader> headers(nl * nv);
  if (zip) {
    parallel_each<Zip>(
        headers.size(), [&] { return open_zip(path); },
        [&](Zip& z, std::size_t i) {
          headers[i] =
              decode_image_header(read_zip_entry(z.get(), path, src.names_[i]), displays[i]);
        });
  } else {
    parallel_each<NoState>(
        headers.size(), [] { return NoState{}; },
        [&](NoState&, std::size_t i) { headers[i] = read_image_header(path / src.names_[i]); });
  }
  for (std::size_t i = 1; i < headers.size(); ++i) {
    if (headers[i].width != headers[0].width || headers[i].height != headers[0].height)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} is {}x{} but {} is {}x{}; all images must have one size",
                              displays[0], headers[0].width, headers[0].height, displays[i],
                              headers[i].width, headers[i].height));
    if (headers[i].format != headers[0].format)
      throw Error(
          Error::Kind::kFormat,
          fmt::format("{} is {} but {} is {}; all images must have one sample format", displays[0],
                      to_string(headers[0].format), displays[i], to_string(headers[i].format)));
  }
  info.width = headers[0].width;
  info.height = headers[0].height;
  info.format = headers[0].format;
  return src;
}

Btf BtfSource::load(const Tile& tile) const {
  const BtfInfo& info = info_;
  const Tile t = tile.empty() ? Tile{0, 0, info.width, info.height} : tile;
  if (t.x < 0 || t.y < 0 || std::int64_t(t.x) + t.width > info.width ||
      std::int64_t(t.y) + t.height > info.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile x={} y={} {}x{} is not inside the images of {} ({}x{}); "
                            "give a tile with 0 <= x, x + width <= {}, 0 <= y, "
                            "y + height <= {}",
                            t.x, t.y, t.width, t.height, info.path.string(), info.width,
                            info.height, info.width, info.height));
  const std::size_t images = info.lights.size() * info.views.size();
  limits::check_memory(double(images) * t.width * t.height * 12.0,
                       fmt::format("loading a {}x{} tile of the {} images of {}", t.width, t.height,
                                   images, info.path.string()),
                       "give a smaller tile (btfgmm fit --tile X,Y,W,H)");
  Btf btf(info.lights, info.views, t.width, t.height, info.format);
  btf.set_origin(t);
  const std::size_t nv = info.views.size();
  const bool zip = info.layout == Layout::kBonnZip;

  auto store = [&](std::span<const std::uint8_t> bytes, const std::string& display, std::size_t i) {
    const ImageHeader h = decode_image_header(bytes, display);
    if (h.width != info.width || h.height != info.height || h.format != info.format)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} is now a {}x{} {} image but was {}x{} {} when the BTF was "
                              "opened; did the files change? Open the BTF again",
                              display, h.width, h.height, to_string(h.format), info.width,
                              info.height, to_string(info.format)));
    const Image img = decode_image(bytes, display, t);
    std::copy(img.rgb.begin(), img.rgb.end(), btf.image(i / nv, i % nv));
  };
  if (zip) {
    parallel_each<Zip>(
        names_.size(), [&] { return open_zip(info.path); },
        [&](Zip& z, std::size_t i) {
          const std::string display = entry_display(info.path, names_[i]);
          store(read_zip_entry(z.get(), info.path, names_[i]), display, i);
        });
  } else {
    parallel_each<NoState>(
        names_.size(), [] { return NoState{}; },
        [&](NoState&, std::size_t i) {
          const fs::path p = info.path / names_[i];
          store(read_file(p), p.string(), i);
        });
  }
  return btf;
}

void write_utia(const Btf& btf, const fs::path& folder, std::optional<ImageFormat> format) {
  const ImageFormat f =
      format.value_or(btf.format() == SampleFormat::kHdr ? ImageFormat::kExr : ImageFormat::kPng);
  if (f == ImageFormat::kJpeg)
    throw Error(Error::Kind::kArgument,
                fmt::format("cannot write {} as JPEG (lossy); write PNG or EXR", folder.string()));
  const char* ext = f == ImageFormat::kExr ? ".exr" : ".png";
  const std::size_t nv = btf.views().size();
  std::vector<fs::path> view_dirs(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    view_dirs[v] = folder / angles(btf.views()[v], "tv", "pv", '_');
    std::error_code ec;
    fs::create_directories(view_dirs[v], ec);
    if (ec)
      throw Error(Error::Kind::kIo, fmt::format("cannot create the folder {}: {}",
                                                view_dirs[v].string(), ec.message()));
  }
  parallel_each<NoState>(
      btf.image_count(), [] { return NoState{}; },
      [&](NoState&, std::size_t i) {
        const std::size_t l = i / nv, v = i % nv;
        const fs::path p = view_dirs[v] / (utia_image_stem(btf.lights()[l], btf.views()[v]) + ext);
        const std::span<const float> px(btf.image(l, v), btf.image_floats());
        if (f == ImageFormat::kExr)
          write_exr(p, btf.width(), btf.height(), px);
        else
          write_png(p, btf.width(), btf.height(), px);
      });
}

}  // namespace btfgmm
