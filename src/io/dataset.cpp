// BTF data sets on disk: UTIA folders (nested or flat), Bonn folders and Bonn zips (read in
// place, io/zip.hpp). Opening one discovers its images in stages: list the files, parse their
// names, build the light and view sets, check that every (light, view) pair has one image,
// and read the headers to check that all images have one size and kind.
#include "btfgmm/io/dataset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/file_kind.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/io/ubo_btf.hpp"
#include "io/angle_names.hpp"
#include "io/parallel_each.hpp"
#include "io/zip.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using detail::angles;
using detail::entry_display;
using detail::NoState;
using detail::parallel_each;
using detail::Zip;

// Relative names (or zip entry names) with their stored sizes.
using StoredFiles = std::vector<std::pair<std::string, std::uint64_t>>;

bool macos_junk(const std::string& rel) {
  const std::string file = rel.substr(rel.rfind('/') + 1);
  return rel.rfind("__MACOSX/", 0) == 0 || rel.find("/__MACOSX/") != std::string::npos ||
         file.rfind("._", 0) == 0;
}

bool is_zip_name(const fs::path& p) {
  return lower(p.extension().string()) == ".zip";
}

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

// ---- 0. the source ---------------------------------------------------------------------

// The error for a file given as a BTF that is not a .zip: what it holds, where that is known
// (io/file_kind.hpp), and what to give instead.
Error not_a_btf(const fs::path& path) {
  const std::vector<std::uint8_t> head = read_file_start(path, 512);
  if (is_model_file_start(head))
    return Error(Error::Kind::kArgument,
                 fmt::format("{0} is a btfgmm model, not a BTF; give the data it was fitted to "
                             "(the model's provenance names it), or go on fitting the model: "
                             "give {0} to the option {1}, the iterations in all to {2} and a new "
                             "model file to {3}",
                             path.string(), option_name("continue"), option_name("iterations"),
                             option_name("output")));
  const std::optional<FileKind> kind = identify_file(head);
  using C = FileKind::Class;
  const std::string fix =
      !kind                       ? ""
      : kind->kind == C::kArchive ? "extract it and give the folder of images it holds"
      : kind->kind == C::kZip     ? "a zip is read when its name ends in .zip: rename it"
      : kind->kind == C::kImage   ? "one image is not a BTF: give the folder that holds the images"
      : kind->kind == C::kCheckpoint
          ? fmt::format("continue the fit it holds by giving {} to the option {}", path.string(),
                        option_name("resume"))
          : "";
  if (fix.empty())
    return Error(Error::Kind::kArgument,
                 fmt::format("{} is a file; give a folder of BTF images or a Bonn .zip archive",
                             path.string()));
  return Error(Error::Kind::kArgument,
               fmt::format("{} is {}, not a BTF; {}", path.string(), kind->what, fix));
}

// Error unless `path` is a folder or a .zip archive; whether it is a zip.
bool is_zip_source(const fs::path& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status))
    throw Error(
        Error::Kind::kIo,
        fmt::format(
            "{} does not exist{}; give a folder of BTF images or a Bonn .zip", path.string(),
            ec && ec != std::errc::no_such_file_or_directory ? " (" + ec.message() + ")" : ""));
  const bool zip = fs::is_regular_file(status);
  if (zip && !is_zip_name(path)) throw not_a_btf(path);
  if (!zip && !fs::is_directory(status))
    throw Error(Error::Kind::kArgument,
                fmt::format("{} is neither a folder nor a .zip archive", path.string()));
  return zip;
}

// ---- 1. the candidate files ------------------------------------------------------------

// Every regular file under the folder (following links), named relative to it.
StoredFiles list_folder(const fs::path& path) {
  StoredFiles files;
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
  return files;
}

// ---- 2. the image names ----------------------------------------------------------------

// An image in a folder named after a view must carry that view in its name.
void check_view_folder(Found& f) {
  const auto slash = f.rel.find_last_of('/');
  if (slash != std::string::npos) {
    const std::string dir = f.rel.substr(0, slash);
    const std::string folder = dir.substr(dir.find_last_of('/') + 1);
    if (const auto v = detail::parse_view_folder(folder)) {
      if (v->theta_deg != f.name.view.theta_deg || v->phi_deg != f.name.view.phi_deg)
        throw Error(Error::Kind::kFormat,
                    fmt::format("{} lies in the view folder {} but its name says view {}; "
                                "move it to a folder {} or rename it",
                                f.display, folder, angles(f.name.view, "tv", "pv", ' '),
                                angles(f.name.view, "tv", "pv", '_')));
      f.in_view_folder = true;
    }
  }
}

// Images in formats btfgmm does not read (TIFF, BMP, ...), by format, for the message that
// says so when nothing else is found.
struct UnreadImages {
  std::map<std::string, std::pair<std::size_t, std::string>> formats;  // format: count, ext
  std::string example;                                                 // one such file

  void add(std::string_view format, const std::string& file, const std::string& rel) {
    auto& [count, ext] = formats[std::string(format)];
    if (count++ == 0) ext = file.substr(file.rfind('.'));
    if (example.empty()) example = rel;
  }
};

// The error for a source with no image btfgmm reads: the formats found instead and how to
// convert them, or the names expected.
Error no_images_error(const fs::path& path, bool zip, std::uint64_t ignored,
                      const UnreadImages& unread) {
  if (unread.formats.empty())
    return Error(Error::Kind::kFormat,
                 fmt::format("no BTF images found in {}{}; expected images named like "
                             "tv000_pv000/tl000_pl000_tv000_pv000.png (UTIA) or "
                             "'00008 tl000 pl000 tv030 pv030.jpg' (Bonn), or a Bonn .zip",
                             path.string(),
                             ignored ? fmt::format(" ({} non-image file{} ignored)", ignored,
                                                   ignored == 1 ? "" : "s")
                                     : ""));
  std::string found;
  for (const auto& [format, at] : unread.formats)
    found += fmt::format("{}{} {} image{} ({})", found.empty() ? "" : " and ", at.first, format,
                         at.first == 1 ? "" : "s", at.second);
  const std::string file = unread.example.substr(unread.example.rfind('/') + 1);
  bool named = true;
  try {
    parse_image_name(file.substr(0, file.rfind('.')) + ".png");
  } catch (const Error&) {
    named = false;
  }
  const std::string ext = unread.formats.begin()->second.second;
  const std::string folder = zip ? "FOLDER" : path.string();
  return Error(
      Error::Kind::kFormat,
      fmt::format("{} holds {} and no image btfgmm reads{}; btfgmm reads PNG (8- or 16-bit), "
                  "JPEG and OpenEXR (.png, .jpg, .jpeg, .exr): {}convert the images keeping their "
                  "names, e.g. with ImageMagick: find {} -name '*{}' -execdir mogrify -format png "
                  "{{}} +",
                  path.string(), found,
                  named ? fmt::format(" (their names are BTF image names, e.g. {}: only the "
                                      "format is wrong)",
                                      unread.example)
                        : std::string(),
                  zip ? "extract the zip to a FOLDER and " : "", folder, ext));
}

// The images among the files (anything else is counted in `ignored`), their names parsed.
std::vector<Found> parse_image_names(const StoredFiles& files, const fs::path& path, bool zip,
                                     std::uint64_t& ignored) {
  std::vector<Found> found;
  UnreadImages unread;
  for (const auto& [rel, bytes] : files) {
    const std::string display = zip ? entry_display(path, rel) : (path / rel).string();
    const std::string file = rel.substr(rel.find_last_of('/') + 1);
    if (macos_junk(rel) || !image_format_from_name(file)) {
      if (const auto format = unread_image_format_from_name(file); format && !macos_junk(rel))
        unread.add(*format, file, rel);
      ++ignored;
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
    check_view_folder(f);
    found.push_back(std::move(f));
  }
  if (found.empty()) throw no_images_error(path, zip, ignored, unread);
  return found;
}

// ---- 3. layout and direction sets ------------------------------------------------------

Layout layout_of(const std::vector<Found>& found, bool zip) {
  const bool indexed = std::any_of(found.begin(), found.end(),
                                   [](const Found& f) { return f.name.index.has_value(); });
  const bool nested =
      std::any_of(found.begin(), found.end(), [](const Found& f) { return f.in_view_folder; });
  return zip       ? Layout::kBonnZip
         : indexed ? Layout::kBonnFolder
         : nested  ? Layout::kUtiaNested
                   : Layout::kUtiaFlat;
}

// The distinct lights and views, each sorted by theta then phi, and where each lies.
struct DirectionIndex {
  std::map<Angles, std::size_t> light_index, view_index;
  std::vector<Direction> lights, views;

  // The pair of an image, light-major (as Btf::image_index).
  std::size_t pair(const Found& f) const {
    return light_index.at(key(f.name.light)) * views.size() + view_index.at(key(f.name.view));
  }
};

DirectionIndex index_directions(const std::vector<Found>& found) {
  DirectionIndex d;
  for (const Found& f : found) {
    d.light_index.emplace(key(f.name.light), 0);
    d.view_index.emplace(key(f.name.view), 0);
  }
  for (auto& [a, i] : d.light_index) {
    i = d.lights.size();
    d.lights.push_back({a.first, a.second});
  }
  for (auto& [a, i] : d.view_index) {
    i = d.views.size();
    d.views.push_back({a.first, a.second});
  }
  return d;
}

// ---- 4. one image per pair -------------------------------------------------------------

// The image of each pair found, by pair index. The pairs found are indexed first (nl x nv may
// be far more than the files: a table of every pair is only made once each has its image).
std::map<std::size_t, const Found*> pair_images(const std::vector<Found>& found,
                                                const DirectionIndex& dirs) {
  std::map<std::size_t, const Found*> present;
  for (const Found& f : found) {
    const std::size_t i = dirs.pair(f);
    const auto [at, fresh] = present.emplace(i, &f);
    if (!fresh)
      throw Error(
          Error::Kind::kFormat,
          fmt::format("two images for light {} and view {}: {} and {}; keep one and "
                      "remove the other",
                      angles(f.name.light, "tl", "pl", ' '), angles(f.name.view, "tv", "pv", ' '),
                      at->second->display, f.display));
  }
  return present;
}

// How the image of a missing pair would be named, in the layout's own form.
std::string missing_image_name(Layout layout, const Direction& light, const Direction& view,
                               const std::string& ext) {
  const std::string stem = utia_image_stem(light, view);
  switch (layout) {
    case Layout::kUtiaNested:
      return angles(view, "tv", "pv", '_') + "/" + stem + ext;
    case Layout::kUtiaFlat:
      return stem + ext;
    default:
      return fmt::format("'NNNNN {} {}{}'", angles(light, "tl", "pl", ' '),
                         angles(view, "tv", "pv", ' '), ext);
  }
}

// Error naming the first five missing pairs unless every pair has its image.
void check_complete(const fs::path& path, const std::map<std::size_t, const Found*>& present,
                    const DirectionIndex& dirs, Layout layout, const std::string& ext) {
  const std::size_t nl = dirs.lights.size(), nv = dirs.views.size();
  std::vector<std::string> missing;
  const std::size_t n_missing = nl * nv - present.size();
  // The first five missing pairs lie within the first present.size() + 5 indices.
  for (std::size_t i = 0; i < nl * nv && missing.size() < 5 && n_missing > 0; ++i) {
    if (present.count(i)) continue;
    missing.push_back(missing_image_name(layout, dirs.lights[i / nv], dirs.views[i % nv], ext));
  }
  if (n_missing)
    throw Error(Error::Kind::kFormat,
                fmt::format("{}: {} of the {} images ({} lights x {} views, the directions "
                            "found in the names) are missing: {}{}; every (light, view) pair "
                            "needs exactly one image",
                            path.string(), n_missing, nl * nv, nl, nv, fmt::join(missing, ", "),
                            n_missing > missing.size() ? ", ..." : ""));
}

// The one image format of all images; Error if they mix formats.
ImageFormat one_image_format(const fs::path& path, const std::vector<Found>& found) {
  for (const Found& f : found)
    if (f.format != found.front().format)
      throw Error(Error::Kind::kFormat,
                  fmt::format("{} mixes image formats: {} and {}; convert all images to one "
                              "format",
                              path.string(), found.front().display, f.display));
  return found.front().format;
}

// ---- 5. headers ------------------------------------------------------------------------

std::vector<ImageHeader> read_headers(const fs::path& path, bool zip,
                                      const std::vector<std::string>& names,
                                      const std::vector<std::string>& displays) {
  std::vector<ImageHeader> headers(names.size());
  if (zip) {
    parallel_each<Zip>(
        headers.size(), [&] { return detail::open_zip(path); },
        [&](Zip& z, std::size_t i) {
          headers[i] =
              decode_image_header(detail::read_zip_entry(z.get(), path, names[i]), displays[i]);
        });
  } else {
    parallel_each<NoState>(
        headers.size(), [] { return NoState{}; },
        [&](NoState&, std::size_t i) { headers[i] = read_image_header(path / names[i]); });
  }
  return headers;
}

// Error unless all images have one size and one sample format.
void check_one_size_and_kind(const std::vector<ImageHeader>& headers,
                             const std::vector<std::string>& displays) {
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
}

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
    case Layout::kUboBtf:
      return "Bonn .btf file";
  }
  return "?";
}

const std::string& BtfSource::image_name(std::size_t light, std::size_t view) const {
  return names_.at(light * info_.views.size() + view);
}

BtfSource BtfSource::open(const fs::path& path) {
  if (is_ubo_btf_file(path)) return open_ubo(path);
  const bool zip = is_zip_source(path);
  BtfSource src;
  BtfInfo& info = src.info_;
  info.path = path;

  // 1. The candidate files: relative names, sorted, with their stored sizes.
  StoredFiles files = zip ? detail::list_zip_files(path) : list_folder(path);
  std::sort(files.begin(), files.end());

  // 2. Parse the image names.
  const std::vector<Found> found = parse_image_names(files, path, zip, info.ignored_files);

  // 3. Layout and direction sets.
  info.layout = layout_of(found, zip);
  const DirectionIndex dirs = index_directions(found);
  info.lights = DirectionSet(dirs.lights);
  info.views = DirectionSet(dirs.views);

  // 4. One image per pair, all of one format.
  const auto present = pair_images(found, dirs);
  check_complete(path, present, dirs, info.layout,
                 fs::path(found.front().rel).extension().string());
  info.image_format = one_image_format(path, found);
  const std::size_t pairs = dirs.lights.size() * dirs.views.size();
  src.names_.resize(pairs);
  std::vector<std::string> displays(pairs);
  for (const auto& [i, f] : present) {
    src.names_[i] = f->rel;
    displays[i] = f->display;
    info.file_bytes += f->bytes;
  }

  // 5. Headers: one size and one sample format.
  const std::vector<ImageHeader> headers = read_headers(path, zip, src.names_, displays);
  check_one_size_and_kind(headers, displays);
  info.width = headers[0].width;
  info.height = headers[0].height;
  info.format = headers[0].format;
  return src;
}

namespace {

// The tile asked for (empty: the whole image), checked to lie inside the images.
Tile tile_inside(const BtfInfo& info, const Tile& tile) {
  const Tile t = tile.or_whole(info.width, info.height);
  if (t.x < 0 || t.y < 0 || std::int64_t(t.x) + t.width > info.width ||
      std::int64_t(t.y) + t.height > info.height)
    throw Error(Error::Kind::kArgument,
                fmt::format("tile x={} y={} {}x{} is not inside the images of {} ({}x{}); "
                            "give a tile with 0 <= x, x + width <= {}, 0 <= y, "
                            "y + height <= {}",
                            t.x, t.y, t.width, t.height, info.path.string(), info.width,
                            info.height, info.width, info.height));
  return t;
}

}  // namespace

Btf BtfSource::load(const Tile& tile) const {
  const BtfInfo& info = info_;
  const Tile t = tile_inside(info, tile);
  const std::size_t images = info.lights.size() * info.views.size();
  limits::check_memory(
      double(images) * t.width * t.height * 12.0,
      fmt::format("loading a {}x{} tile of the {} images of {}", t.width, t.height, images,
                  info.path.string()),
      fmt::format("give a smaller tile (the option {}: X,Y,W,H)", option_name("tile")));
  Btf btf(info.lights, info.views, t.width, t.height, info.format);
  btf.set_origin(t);
  if (map_) btf.set_made_from(map_->description);
  const std::size_t nv = info.views.size();
  read_tiles(t, 0, images, [&](std::size_t i, std::span<const float> rgb) {
    std::copy(rgb.begin(), rgb.end(), btf.image(i / nv, i % nv));
  });
  return btf;
}

void BtfSource::read_tiles(const Tile& tile, std::size_t first, std::size_t last,
                           const TileSink& take) const {
  if (map_) return read_mapped_tiles(tile, first, last, take);
  if (ubo_) return read_ubo_tiles(tile, first, last, take);
  const BtfInfo& info = info_;
  const Tile t = tile_inside(info, tile);
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
    take(i, img.rgb);
  };
  if (zip) {
    parallel_each<Zip>(
        last - first, [&] { return detail::open_zip(info.path); },
        [&](Zip& z, std::size_t k) {
          const std::size_t i = first + k;
          const std::string display = entry_display(info.path, names_[i]);
          store(detail::read_zip_entry(z.get(), info.path, names_[i]), display, i);
        });
  } else {
    parallel_each<NoState>(
        last - first, [] { return NoState{}; },
        [&](NoState&, std::size_t k) {
          const std::size_t i = first + k;
          const fs::path p = info.path / names_[i];
          store(read_whole_file(p, "image", "it is not a BTF image; move it out of the folder",
                                Error::Kind::kIo),
                p.string(), i);
        });
  }
}

}  // namespace btfgmm
