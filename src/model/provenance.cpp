// A model's provenance: the tile's content hash, and the provenance section of the model file
// (docs/FORMAT.md, "Provenance").
#include "btfgmm/model/provenance.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "btfgmm/core/limits.hpp"
#include "model/byte_io.hpp"

namespace btfgmm {
namespace {

constexpr std::uint32_t kMaxSource = 4096, kMaxSettings = 64, kMaxName = 64, kMaxValue = 1024;
constexpr std::uint32_t kMaxIterations = 1u << 20;
constexpr std::size_t kIterationBytes = 8 + 8 + 4;

// Text as written: at most `limit` bytes, control characters (which a reader refuses, as
// they would garble a terminal) replaced by '?'.
std::string clean_text(const std::string& s, std::size_t limit) {
  std::string out = s.substr(0, limit);
  for (char& ch : out)
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) ch = '?';
  return out;
}

std::string get_text(detail::ByteReader& r, const char* field, std::uint32_t limit,
                     bool may_be_empty) {
  const auto n = r.get<std::uint32_t>(field);
  if (n > limit || (n == 0 && !may_be_empty))
    r.fail(fmt::format("provenance field '{}' of {} bytes (1 to {} allowed)", field, n, limit));
  std::string s = r.text_of_size(n, field);
  for (char ch : s)
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f)
      r.fail(fmt::format("provenance field '{}' holds a control character", field));
  return s;
}

double get_seconds(detail::ByteReader& r, const char* field) {
  const double s = r.get<double>(field);
  if (!(s >= 0.0) || !std::isfinite(s))
    r.fail(fmt::format("provenance field '{}' is {}, not a time in seconds", field, s));
  return s;
}

void get_source(detail::ByteReader& r, DataFingerprint& d) {
  d.source.name = get_text(r, "source", kMaxSource, true);
  const auto w = r.get<std::uint32_t>("image width"), h = r.get<std::uint32_t>("image height");
  if ((w == 0) != (h == 0) || w > std::uint32_t(limits::kMaxImageSide) ||
      h > std::uint32_t(limits::kMaxImageSide))
    r.fail(fmt::format("the source's image size {}x{} is out of range", w, h));
  d.source.image_width = int(w);
  d.source.image_height = int(h);
  d.content_hash = r.get<std::uint64_t>("content hash");
}

void get_settings(detail::ByteReader& r, FitLog& log) {
  const auto k = r.get<std::uint32_t>("settings");
  if (k > kMaxSettings) r.fail(fmt::format("{} fit settings (at most {})", k, kMaxSettings));
  for (std::uint32_t i = 0; i < k; ++i) {
    std::string name = get_text(r, "setting name", kMaxName, false);
    std::string value = get_text(r, "setting value", kMaxValue, true);
    log.settings.emplace_back(std::move(name), std::move(value));
  }
}

void get_iterations(detail::ByteReader& r, FitLog& log) {
  const auto n = r.get<std::uint32_t>("iterations logged");
  if (n > kMaxIterations || std::size_t(n) * kIterationBytes > r.remaining())
    r.fail(fmt::format("{} iterations logged do not fit the provenance", n));
  log.iterations.resize(n);
  double before = 0.0;
  for (IterationRecord& it : log.iterations) {
    it.log_likelihood = r.get<double>("iteration log-likelihood");
    it.seconds = get_seconds(r, "iteration seconds");
    it.components = r.get<std::uint32_t>("iteration components");
    if (!std::isfinite(it.log_likelihood) || it.components == 0 || it.seconds < before)
      r.fail("an iteration logged has a non-finite L, no components or an earlier time");
    before = it.seconds;
  }
}

}  // namespace

std::uint64_t content_hash_add(std::uint64_t h, std::span<const float> v) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(v.data());
  for (std::size_t i = 0, n = v.size_bytes(); i < n; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;  // the FNV-1a prime
  }
  return h;
}

std::uint64_t tile_content_hash(const Btf& tile) {
  return content_hash_add(kContentHashBasis, tile.data());
}

DataFingerprint fingerprint_of(const Btf& tile, DataSource source) {
  return {std::move(source), tile_content_hash(tile)};
}

std::string hash_text(std::uint64_t hash) {
  return fmt::format("{:016x}", hash);
}

std::string describe_source(const Provenance& p, const Tile& tile) {
  if (!p.recorded) return "no provenance recorded";
  const DataSource& s = p.data.source;
  for (const auto& [setting, value] : p.fit.settings)
    if (setting == kTileSetting)  // a made tile: its own images, cut from the source's
      return fmt::format("{} (its {}, content hash {})",
                         s.name.empty() ? std::string("data not named") : "'" + s.name + "'", value,
                         hash_text(p.data.content_hash));
  const std::string images =
      s.image_width > 0 ? fmt::format(" of {}x{} images", s.image_width, s.image_height) : "";
  return fmt::format("{} (its {}x{} tile at ({}, {}){}, content hash {})",
                     s.name.empty() ? std::string("data not named") : "'" + s.name + "'",
                     tile.width, tile.height, tile.x, tile.y, images,
                     hash_text(p.data.content_hash));
}

namespace detail {

void put_provenance(ByteWriter& w, const Provenance& p) {
  const DataSource& s = p.data.source;
  w.text(clean_text(s.name, kMaxSource));
  w.put<std::uint32_t>(std::uint32_t(s.image_width));
  w.put<std::uint32_t>(std::uint32_t(s.image_height));
  w.put<std::uint64_t>(p.data.content_hash);
  // No time is written (0 in its place): the file is a function of the data, the settings and
  // the seed, the same at any load, with any thread count, and after a resume (the fit's
  // times are the run's: printed, and in fit --log).
  w.put<double>(0.0);
  w.put<std::uint32_t>(std::max<std::uint32_t>(p.fit.runs, 1));
  const std::size_t k = std::min<std::size_t>(p.fit.settings.size(), kMaxSettings);
  w.put<std::uint32_t>(std::uint32_t(k));
  for (std::size_t i = 0; i < k; ++i) {
    const std::string name = clean_text(p.fit.settings[i].first, kMaxName);
    w.text(name.empty() ? std::string("?") : name);
    w.text(clean_text(p.fit.settings[i].second, kMaxValue));
  }
  w.put<std::uint32_t>(std::uint32_t(p.fit.iterations.size()));
  for (const IterationRecord& it : p.fit.iterations) {
    w.put<double>(it.log_likelihood);
    w.put<double>(0.0);
    w.put<std::uint32_t>(it.components);
  }
}

Provenance get_provenance(ByteReader& r) {
  Provenance p;
  p.recorded = true;
  get_source(r, p.data);
  p.fit.seconds = get_seconds(r, "fit seconds");
  p.fit.runs = r.get<std::uint32_t>("runs");
  if (p.fit.runs == 0) r.fail("the fit is logged with 0 runs");
  get_settings(r, p.fit);
  get_iterations(r, p.fit);
  if (r.remaining() != 0)
    r.fail(fmt::format("the provenance holds {} bytes after its last field", r.remaining()));
  return p;
}

}  // namespace detail
}  // namespace btfgmm
