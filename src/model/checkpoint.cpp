// Fit checkpoints: magic, version, payload, CRC-32 (the model file's conventions), the EM
// state in full double precision so that a resumed fit continues bit for bit.
#include "btfgmm/model/checkpoint.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstring>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/model/provenance.hpp"
#include "model/byte_io.hpp"

namespace btfgmm {
namespace {

constexpr std::uint8_t kMagic[8] = {0x89, 'B', 'T', 'F', 'C', 'K', 'P', '\n'};
// 2: the runs so far, and each iteration's time and components alive (the model's
// provenance); 1 had neither.
constexpr std::uint32_t kVersion = 3;  // 3: the made tile's description (2: none)
constexpr const char* kWhat = "checkpoint";
constexpr const char* kFix = "start the fit again without `resume`";

void fnv(std::uint64_t& h, const void* data, std::size_t n) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;
  }
}

}  // namespace

std::uint64_t data_fingerprint(const DirectionSet& lights, const DirectionSet& views, int width,
                               int height, std::uint64_t content_hash) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  const int size[2] = {width, height};
  fnv(h, size, sizeof size);
  for (const auto* set : {&lights, &views})
    for (const Direction& d : *set) fnv(h, &d, sizeof d);
  fnv(h, &content_hash, sizeof content_hash);
  return h;
}

std::uint64_t btf_fingerprint(const Btf& btf) {
  return data_fingerprint(btf.lights(), btf.views(), btf.width(), btf.height(),
                          tile_content_hash(btf));
}

void save_checkpoint(const FitCheckpoint& c, const std::filesystem::path& path) {
  detail::ByteWriter w;
  w.bytes.assign(kMagic, kMagic + 8);
  w.put<std::uint32_t>(kVersion);
  w.text(c.input);
  w.text(c.output);
  w.put<std::int32_t>(c.tile.x);
  w.put<std::int32_t>(c.tile.y);
  w.put<std::int32_t>(c.tile.width);
  w.put<std::int32_t>(c.tile.height);
  w.text(c.made_from);
  w.put<std::uint64_t>(c.components);
  w.put<std::uint64_t>(c.seed);
  w.put<std::int32_t>(c.max_iterations);
  w.put<double>(c.epsilon);
  w.put<std::uint32_t>(std::uint32_t(c.precision));
  w.put<std::uint64_t>(c.data_fingerprint);
  w.put<std::uint32_t>(c.runs);
  const EmResult& r = c.state.result;
  w.put<std::int32_t>(r.iterations);
  w.put<std::uint64_t>(r.dropped);
  w.put<std::uint8_t>(r.converged ? 1 : 0);
  w.put<std::uint32_t>(std::uint32_t(r.log_likelihood.size()));
  for (std::size_t i = 0; i < r.log_likelihood.size(); ++i) {
    w.put<double>(r.log_likelihood[i]);
    w.put<double>(i < r.seconds.size() ? r.seconds[i] : 0.0);
    w.put<std::uint32_t>(i < r.components.size() ? r.components[i] : 0);
  }
  const ProductMixture& m = c.state.mixture;
  w.put<std::uint32_t>(std::uint32_t(m.size()));
  for (std::size_t k = 0; k < m.size(); ++k) {
    w.put<double>(m.weight[k]);
    for (double v : m.mean[k]) w.put<double>(v);
    for (double v : m.var[k]) w.put<double>(v);
  }
  detail::append_crc32(w);
  write_file_atomically(path, w.bytes, kWhat);
}

FitCheckpoint load_checkpoint(const std::filesystem::path& path) {
  const std::vector<std::uint8_t> bytes = read_whole_file(path, kWhat);
  const std::string name = path.string();
  if (bytes.size() < 16 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw Error(Error::Kind::kFormat,
                fmt::format("'{}' is not a btfgmm checkpoint (what a fit writes with the "
                            "option {}); {}",
                            name, option_name("checkpoint"), kFix));
  if (!detail::crc32_holds(bytes))
    throw Error(Error::Kind::kFormat,
                fmt::format("checkpoint '{}' is truncated or corrupted (checksum mismatch); {}",
                            name, kFix));
  const std::span<const std::uint8_t> all(bytes);
  detail::ByteReader r(all.subspan(8, bytes.size() - 12), kWhat, name, kFix);
  const auto version = r.get<std::uint32_t>("version");
  if (version != kVersion && version != 2)
    throw Error(
        Error::Kind::kFormat,
        fmt::format("checkpoint '{}' has version {}, written by {} btfgmm (this btfgmm "
                    "reads versions 2 to {}); resume it with that btfgmm, or {}",
                    name, version, version < kVersion ? "an older" : "a newer", kVersion, kFix));
  FitCheckpoint c;
  c.input = r.text("input");
  c.output = r.text("output");
  c.tile.x = r.get<std::int32_t>("tile x");
  c.tile.y = r.get<std::int32_t>("tile y");
  c.tile.width = r.get<std::int32_t>("tile width");
  c.tile.height = r.get<std::int32_t>("tile height");
  if (version >= 3) c.made_from = r.text("made tile");
  c.components = r.get<std::uint64_t>("components");
  c.seed = r.get<std::uint64_t>("seed");
  c.max_iterations = r.get<std::int32_t>("max iterations");
  c.epsilon = r.get<double>("epsilon");
  const auto precision = r.get<std::uint32_t>("precision");
  if (precision > 2) r.fail("unknown precision");  // 2: compact (model.hpp)
  c.precision = Precision(precision);
  c.data_fingerprint = r.get<std::uint64_t>("data fingerprint");
  c.runs = r.get<std::uint32_t>("runs");
  EmResult& res = c.state.result;
  res.iterations = r.get<std::int32_t>("iterations");
  res.dropped = r.get<std::uint64_t>("dropped");
  const auto converged = r.get<std::uint8_t>("converged");
  if (converged > 1) r.fail("the converged flag is neither 0 nor 1");
  res.converged = converged == 1;
  const auto n = r.get<std::uint32_t>("history");
  if (std::size_t(n) * 20 > r.remaining() || int(n) != res.iterations)
    r.fail("the log-likelihood history does not match the iteration count");
  for (std::uint32_t i = 0; i < n; ++i) {
    res.log_likelihood.push_back(r.get<double>("log-likelihood"));
    res.seconds.push_back(r.get<double>("seconds"));
    res.components.push_back(r.get<std::uint32_t>("components alive"));
  }
  const auto m = r.get<std::uint32_t>("components");
  if (m == 0 || std::size_t(m) * 19 * 8 != r.remaining())
    r.fail(fmt::format("{} components do not fit the {} bytes left", m, r.remaining()));
  ProductMixture& mix = c.state.mixture;
  mix.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    mix.weight[k] = r.get<double>("weight");
    for (double& v : mix.mean[k]) v = r.get<double>("mean");
    for (double& v : mix.var[k]) v = r.get<double>("variance");
  }
  return c;
}

}  // namespace btfgmm
