// The .btfgmm model file (docs/FORMAT.md): magic, version, flags, payload, CRC-32.
#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/file_kind.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "model/byte_io.hpp"
#include "model/compact.hpp"

namespace btfgmm {
namespace {

constexpr std::uint8_t kMagic[8] = {0x89, 'B', 'T', 'F', 'G', 'M', 'M', '\n'};
constexpr std::size_t kHeaderBytes = 24, kTrailerBytes = 4;
constexpr std::uint32_t kDirectionsExplicit = 0, kDirectionsUbo81 = 1;
constexpr std::size_t kMaxMethodTag = 32;

using Writer = detail::ByteWriter;
using Reader = detail::ByteReader;

}  // namespace

namespace detail {

void put_directions(Writer& w, const DirectionSet& s) {
  if (s == DirectionSet::ubo81()) {
    w.put<std::uint32_t>(kDirectionsUbo81);
    return;
  }
  w.put<std::uint32_t>(kDirectionsExplicit);
  w.put<std::uint32_t>(std::uint32_t(s.size()));
  for (const auto& d : s) {
    w.put<double>(d.theta_deg);
    w.put<double>(d.phi_deg);
  }
}

DirectionSet get_directions(Reader& r, const char* what) {
  const auto kind = r.get<std::uint32_t>(what);
  if (kind == kDirectionsUbo81) return DirectionSet::ubo81();
  if (kind != kDirectionsExplicit) r.fail(fmt::format("unknown {} kind {}", what, kind));
  const auto n = r.get<std::uint32_t>(what);
  if (n == 0 || std::size_t(n) * 16 > r.remaining())
    r.fail(fmt::format("{} count {} does not fit the file", what, n));
  std::vector<Direction> dirs(n);
  for (auto& d : dirs) {
    d.theta_deg = r.get<double>(what);
    d.phi_deg = r.get<double>(what);
    if (!(d.theta_deg >= 0.0 && d.theta_deg <= 90.0 && std::isfinite(d.phi_deg)))
      r.fail(fmt::format("a {} direction ({}, {}) is off the hemisphere", what, d.theta_deg,
                         d.phi_deg));
  }
  return DirectionSet(std::move(dirs));
}

void put_tile(Writer& w, int width, int height, const Tile& origin, SampleFormat format) {
  w.put<std::uint32_t>(std::uint32_t(width));
  w.put<std::uint32_t>(std::uint32_t(height));
  w.put<std::int32_t>(origin.x);
  w.put<std::int32_t>(origin.y);
  w.put<std::uint32_t>(std::uint32_t(format));
}

void get_tile(Reader& r, int& width, int& height, Tile& origin, SampleFormat& format) {
  const auto w = r.get<std::uint32_t>("width"), h = r.get<std::uint32_t>("height");
  // The tile was cut from an image: no larger than the largest image read.
  if (w < 1 || h < 1 || w > std::uint32_t(limits::kMaxImageSide) ||
      h > std::uint32_t(limits::kMaxImageSide) ||
      std::int64_t(w) * std::int64_t(h) > limits::kMaxImagePixels)
    r.fail(fmt::format("tile size {}x{} is out of range", w, h));
  width = int(w);
  height = int(h);
  origin.x = r.get<std::int32_t>("origin x");
  origin.y = r.get<std::int32_t>("origin y");
  if (origin.x < 0 || origin.y < 0 || origin.x > limits::kMaxImageSide - width ||
      origin.y > limits::kMaxImageSide - height)
    r.fail(fmt::format("the tile's origin ({}, {}) is outside any image", origin.x, origin.y));
  origin.width = width;
  origin.height = height;
  const auto f = r.get<std::uint32_t>("sample format");
  if (f > 2) r.fail(fmt::format("unknown sample format {}", f));
  format = SampleFormat(f);
}

}  // namespace detail

namespace {

using detail::get_directions;
using detail::put_directions;

// The header's fields after the magic bytes.
struct Header {
  std::uint32_t version = 0, flags = 0;
  std::uint64_t payload = 0;
};

// Throws Error(kFormat) for an empty file or one that does not start with the magic bytes,
// saying what it is instead (io/file_kind.hpp) and what to do with it.
void check_magic(std::span<const std::uint8_t> bytes, const std::string& name) {
  if (bytes.empty())
    throw Error(Error::Kind::kFormat,
                fmt::format("model file '{}' is empty (0 bytes); fit the model again", name));
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), kMagic, 8) == 0) return;
  const std::optional<FileKind> kind =
      identify_file(bytes.first(std::min<std::size_t>(bytes.size(), 512)));
  if (!kind)
    throw Error(Error::Kind::kFormat,
                fmt::format("'{}' is not a btfgmm model file: it does not start with the btfgmm "
                            "magic bytes; give a .btfgmm model file (what a fit writes)",
                            name));
  using C = FileKind::Class;
  const std::string fix =
      kind->kind == C::kArchive ? "extract it and fit the BTF images it holds (a folder of "
                                  "images), then give the model file here"
      : kind->kind == C::kZip
          ? fmt::format(
                "if it holds a BTF (a Bonn zip, read in place), fit a model to '{}', "
                "then give the model file here",
                name)
      : kind->kind == C::kImage ? "a model is fitted to a folder of BTF images: fit the folder "
                                  "that holds them, then give the model file here"
      : kind->kind == C::kCheckpoint
          ? fmt::format(
                "it holds a fit that has not finished: continue it by giving '{}' to "
                "the option {}, which writes the model",
                name, option_name("resume"))
          : "give a .btfgmm model file (what a fit writes)";
  throw Error(Error::Kind::kFormat,
              fmt::format("'{}' is {}, not a btfgmm model; {}", name, kind->what, fix));
}

// The header, checked against the file: a version this btfgmm reads, the payload size, the
// CRC-32 and known flags.
Header read_header(std::span<const std::uint8_t> bytes, const std::string& name) {
  if (bytes.size() < kHeaderBytes + kTrailerBytes)
    throw Error(Error::Kind::kFormat,
                fmt::format("model file '{}' is truncated ({} bytes, less than its header); "
                            "fit or copy it again",
                            name, bytes.size()));
  Reader hr(bytes.subspan(8, kHeaderBytes - 8), "model file", name, "fit or copy it again");
  Header h;
  h.version = hr.get<std::uint32_t>("version");
  h.flags = hr.get<std::uint32_t>("flags");
  h.payload = hr.get<std::uint64_t>("payload size");
  if (h.version > kModelFormatVersion)
    throw Error(Error::Kind::kFormat,
                fmt::format("model file '{}' has format version {}, newer than the version {} "
                            "this btfgmm reads; use a newer btfgmm",
                            name, h.version, kModelFormatVersion));
  if (h.version == 0)
    throw Error(Error::Kind::kFormat, fmt::format("model file '{}' has format version 0, "
                                                  "which no btfgmm writes; it is corrupted",
                                                  name));
  if (h.payload != bytes.size() - kHeaderBytes - kTrailerBytes)
    throw Error(
        Error::Kind::kFormat,
        fmt::format("model file '{}' is {} bytes, a payload of {}, but its header says "
                    "a payload of {} bytes; it is truncated or has trailing data: fit "
                    "or copy it again",
                    name, bytes.size(), bytes.size() - kHeaderBytes - kTrailerBytes, h.payload));
  std::uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  const auto crc = std::uint32_t(crc32(0L, bytes.data(), uInt(bytes.size() - 4)));
  if (crc != stored_crc)
    throw Error(Error::Kind::kFormat,
                fmt::format("model file '{}' is corrupted (CRC-32 {:08x}, stored {:08x}); "
                            "copy or fit it again",
                            name, crc, stored_crc));
  // Flags 2 (the mixture's compact encoding) came with version 4 and went with version 5,
  // which writes its predicted mean BRDF (flags 6) instead.
  // Flags 8 (the texture models' image moments) came with version 6 and went with version 7,
  // which writes them predicted (flags 24) instead.
  const bool known =
      h.flags <= 1 || (h.flags == 2 && h.version == 4) ||
      (h.flags == (2 | kPredictedMeanBrdf) && h.version >= 5) ||
      (h.flags == kImageMoments && h.version == 6) ||
      (h.flags == (kImageMoments | kPredictedImageMoments) && h.version >= 7) ||
      (h.flags == (kImageMoments | kPredictedImageMoments | kReliefStructure) && h.version >= 8);
  if (!known)
    throw Error(Error::Kind::kFormat,
                fmt::format("model file '{}' has unknown flags {:#x}", name, h.flags));
  return h;
}

// How the model was fitted.
void read_settings(Reader& r, FitSettings& s) {
  s.components = r.get<std::uint32_t>("components requested");
  s.max_iterations = r.get<std::uint32_t>("max iterations");
  s.epsilon = r.get<double>("epsilon");
  s.seed = r.get<std::uint64_t>("seed");
  s.iterations = r.get<std::uint32_t>("iterations");
  s.dropped = r.get<std::uint32_t>("dropped");
  s.log_likelihood = r.get<double>("log-likelihood");
}

// The mixture's components and the mean BRDF, which must fill the rest of the payload.
void read_components(Reader& r, BtfModel& m, detail::MeanBrdfCoding coding) {
  const Precision p = m.precision;
  if (p == Precision::kCompact) return detail::get_compact_components(r, m, coding);
  const auto count = r.get<std::uint32_t>("components");
  const std::size_t real_bytes = p == Precision::kF16 ? 2 : 4;
  if (double(m.lights.size()) * double(m.views.size()) > double(r.remaining()))
    r.fail(fmt::format("{} x {} directions need a larger mean BRDF than the file holds",
                       m.lights.size(), m.views.size()));
  const std::size_t expect = std::size_t(count) * (4 + 18 * real_bytes) +
                             m.lights.size() * m.views.size() * 3 * real_bytes;
  if (count == 0 || expect != r.remaining())
    r.fail(fmt::format("{} components and {} x {} directions need {} more bytes, the file has {}",
                       count, m.lights.size(), m.views.size(), expect, r.remaining()));
  m.mixture.resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    m.mixture.weight[k] = double(r.get<float>("weight"));
    for (int n = 0; n < kVariables; ++n) m.mixture.mean[k][n] = r.real(p, "mean");
    for (int n = 0; n < kVariables; ++n) {
      const double sd = r.real(p, "sigma");
      m.mixture.var[k][n] = sd * sd;
    }
    bool ok = m.mixture.weight[k] > 0.0 && std::isfinite(m.mixture.weight[k]);
    for (int n = 0; n < kVariables; ++n)
      ok = ok && std::isfinite(m.mixture.mean[k][n]) && m.mixture.var[k][n] > 0.0 &&
           std::isfinite(m.mixture.var[k][n]);
    if (!ok) r.fail(fmt::format("component {} has a non-finite or non-positive parameter", k));
  }
  m.mean_brdf.resize(m.lights.size() * m.views.size() * 3);
  for (float& v : m.mean_brdf) {
    v = float(r.real(p, "mean BRDF"));
    if (!std::isfinite(v)) r.fail("the mean BRDF holds a non-finite value");
  }
}

// The mixture in 16-bit floats must read back: no mean or deviation beyond kHalfMax, no
// deviation that rounds to zero. The colour refit can leave cancelling colour means of tens of
// thousands of levels where components overlap (a 25 x 25 knit at M = 600 reaches 68,659).
void check_fits_in_f16(const BtfModel& m) {
  static constexpr const char* kVariable[kVariables] = {
      "x", "y", "alpha_i", "beta_i", "alpha_v", "beta_v", "r", "g", "b"};
  auto refuse = [](const std::string& what, double v) {
    throw Error(Error::Kind::kArgument,
                fmt::format("the mixture cannot be stored as f16: {} is {:.6g}, outside a 16-bit "
                            "float's range (magnitudes up to {:g}, deviations above zero), and "
                            "its file would not read back; store it as compact (the default) "
                            "or f32",
                            what, v, detail::kHalfMax));
  };
  for (std::size_t k = 0; k < m.mixture.size(); ++k)
    for (int n = 0; n < kVariables; ++n) {
      const double mean = m.mixture.mean[k][n], sd = std::sqrt(m.mixture.var[k][n]);
      if (!(std::abs(mean) <= detail::kHalfMax))
        refuse(fmt::format("component {}'s mean of {}", k, kVariable[n]), mean);
      if (!(sd <= detail::kHalfMax) || float(Imath::half(float(sd))) <= 0.0f)
        refuse(fmt::format("component {}'s deviation in {}", k, kVariable[n]), sd);
    }
  for (float v : m.mean_brdf)
    if (!(std::abs(v) <= detail::kHalfMax)) refuse("a value of the mean BRDF", v);
}

}  // namespace

std::vector<std::uint8_t> mixture_payload(const BtfModel& m) {
  const Precision p = m.precision;
  Writer w;
  detail::put_tile(w, m.width, m.height, m.origin, m.format);
  put_directions(w, m.lights);
  put_directions(w, m.views);
  for (double u : m.scaling.unit) w.put<double>(u);
  const FitSettings& s = m.settings;
  w.put<std::uint32_t>(s.components);
  w.put<std::uint32_t>(s.max_iterations);
  w.put<double>(s.epsilon);
  w.put<std::uint64_t>(s.seed);
  w.put<std::uint32_t>(s.iterations);
  w.put<std::uint32_t>(s.dropped);
  w.put<double>(s.log_likelihood);
  if (p == Precision::kCompact) {
    detail::put_compact_components(w, m);
    return std::move(w.bytes);
  }
  if (p == Precision::kF16) check_fits_in_f16(m);
  w.put<std::uint32_t>(std::uint32_t(m.mixture.size()));
  for (std::size_t k = 0; k < m.mixture.size(); ++k) {
    w.put<float>(float(m.mixture.weight[k]));
    for (int n = 0; n < kVariables; ++n) w.real(m.mixture.mean[k][n], p);
    for (int n = 0; n < kVariables; ++n) w.real(std::sqrt(m.mixture.var[k][n]), p);
  }
  for (float v : m.mean_brdf) w.real(v, p);
  return std::move(w.bytes);
}

std::vector<std::uint8_t> model_file_bytes(std::string_view method, std::uint32_t flags,
                                           const Provenance& provenance,
                                           std::span<const std::uint8_t> payload) {
  Writer body;
  body.text(std::string(method));
  Writer section;
  if (provenance.recorded) detail::put_provenance(section, provenance);
  body.put<std::uint32_t>(std::uint32_t(section.bytes.size()));
  body.bytes.insert(body.bytes.end(), section.bytes.begin(), section.bytes.end());
  body.bytes.insert(body.bytes.end(), payload.begin(), payload.end());
  std::vector<std::uint8_t> out(kMagic, kMagic + 8);
  Writer h;
  h.put<std::uint32_t>(kModelFormatVersion);
  h.put<std::uint32_t>(flags);
  h.put<std::uint64_t>(std::uint64_t(body.bytes.size()));
  out.insert(out.end(), h.bytes.begin(), h.bytes.end());
  out.insert(out.end(), body.bytes.begin(), body.bytes.end());
  const std::uint32_t crc = std::uint32_t(crc32(0L, out.data(), uInt(out.size())));
  Writer t;
  t.put<std::uint32_t>(crc);
  out.insert(out.end(), t.bytes.begin(), t.bytes.end());
  return out;
}

BtfModel read_mixture_payload(std::span<const std::uint8_t> payload, std::uint32_t flags,
                              const std::string& name) {
  BtfModel m;
  m.precision = Precision(flags & ~kPredictedMeanBrdf);
  Reader r(payload, "model file", name, "fit the model again");
  if (std::uint32_t(m.precision) > 2 ||
      ((flags & kPredictedMeanBrdf) && m.precision != Precision::kCompact))
    r.fail(fmt::format("flags {:#x} name no encoding of a Gaussian mixture", flags));
  detail::get_tile(r, m.width, m.height, m.origin, m.format);
  m.lights = get_directions(r, "light directions");
  m.views = get_directions(r, "view directions");
  for (double& u : m.scaling.unit) {
    u = r.get<double>("variable unit");
    if (!(u > 0.0) || !std::isfinite(u)) r.fail(fmt::format("variable unit {} is not positive", u));
  }
  read_settings(r, m.settings);
  read_components(r, m,
                  flags & kPredictedMeanBrdf ? detail::MeanBrdfCoding::kPredicted
                                             : detail::MeanBrdfCoding::kViewDeltas);
  return m;
}

ModelFileContents open_model_file(std::span<const std::uint8_t> bytes, const std::string& name) {
  check_magic(bytes, name);
  const Header header = read_header(bytes, name);
  ModelFileContents c;
  c.version = header.version;
  c.flags = header.flags;
  c.payload = bytes.subspan(kHeaderBytes, std::size_t(header.payload));
  if (header.version == 1) {  // version 1 held a Gaussian mixture only, with no tag
    c.method = std::string(kMixtureMethod);
    return c;
  }
  Reader r(c.payload, "model file", name, "fit the model again");
  const auto n = r.get<std::uint32_t>("method");
  if (n == 0 || n > kMaxMethodTag) r.fail(fmt::format("method name of {} bytes", n));
  c.method = r.text_of_size(n, "method");
  for (char ch : c.method)
    if (!((ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '-'))
      r.fail("the method name holds a character other than a-z, 0-9 and '-'");
  if (header.version >= 3) {  // the provenance section, empty where none was recorded
    const auto size = r.get<std::uint32_t>("provenance size");
    if (size > r.remaining())
      r.fail(fmt::format("a provenance of {} bytes, more than the file holds", size));
    if (size > 0) {
      Reader pr(c.payload.subspan(r.pos(), size), "model file", name, "fit the model again");
      c.provenance = detail::get_provenance(pr);
    }
    c.payload = c.payload.subspan(r.pos() + size);
    return c;
  }
  c.payload = c.payload.subspan(r.pos());
  return c;
}

std::uint32_t mixture_file_flags(const BtfModel& m) {
  const auto precision = std::uint32_t(m.precision);
  return m.precision == Precision::kCompact ? precision | kPredictedMeanBrdf : precision;
}

std::vector<std::uint8_t> serialize_model(const BtfModel& m) {
  return model_file_bytes(kMixtureMethod, mixture_file_flags(m), m.provenance, mixture_payload(m));
}

BtfModel deserialize_model(std::span<const std::uint8_t> bytes, const std::string& name) {
  const ModelFileContents c = open_model_file(bytes, name);
  if (c.method != kMixtureMethod)
    throw Error(Error::Kind::kFormat,
                fmt::format("model file '{}' holds a '{}' model, not a Gaussian mixture; read it "
                            "with load_representation (methods/registry.hpp)",
                            name, c.method));
  BtfModel m = read_mixture_payload(c.payload, c.flags, name);
  m.provenance = c.provenance;
  return m;
}

void save_model(const BtfModel& model, const std::filesystem::path& path) {
  write_file_atomically(path, serialize_model(model), "model file");
}

BtfModel load_model(const std::filesystem::path& path) {
  return deserialize_model(read_whole_file(path, "model file"), path.string());
}

}  // namespace btfgmm
