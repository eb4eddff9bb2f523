// Reading a Bonn .btf file's header and angular factors (docs/FORMAT.md, "Bonn .btf files"):
// the signature, the common header (metadata, the views with their light lists as spherical
// angles, the size, the rotations), then the DFMF or FMF sections. Every field is checked as it
// is read; a value that cannot be right stops the reading with the file, the field and the fix.
#include "btfgmm/io/ubo_btf.hpp"

#include <Imath/half.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <numbers>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/io/files.hpp"
#include "io/ubo_btf_source.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

constexpr const char* kDfmfSignature = "!DFMF08FCR";
constexpr const char* kFmfSignature = "!FMF12FCER";
constexpr std::uint32_t kMaxDirections = 100000;
constexpr std::uint32_t kMaxSide = 1u << 20;

class FileSource final : public UboBtf::Source {
 public:
  explicit FileSource(const fs::path& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0)
      throw Error(Error::Kind::kIo, fmt::format("cannot open {}: {}; check the path and its "
                                                "permissions",
                                                path.string(), std::strerror(errno)));
    const off_t end = ::lseek(fd_, 0, SEEK_END);
    if (end < 0) {
      ::close(fd_);
      throw Error(Error::Kind::kIo,
                  fmt::format("cannot read {}: {}", path.string(), std::strerror(errno)));
    }
    size_ = std::uint64_t(end);
  }
  ~FileSource() override { ::close(fd_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;

  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::size_t n, void* dst) const override {
    auto* out = static_cast<char*>(dst);
    while (n > 0) {
      const ssize_t got = ::pread(fd_, out, n, off_t(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0)
        throw Error(
            Error::Kind::kIo,
            fmt::format("cannot read {} at byte {}: {}; did the file change?", path_.string(),
                        offset, got < 0 ? std::strerror(errno) : "it ends there"));
      out += got;
      offset += std::uint64_t(got);
      n -= std::size_t(got);
    }
  }

 private:
  fs::path path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

class MemorySource final : public UboBtf::Source {
 public:
  explicit MemorySource(std::vector<std::uint8_t> bytes) : bytes_(std::move(bytes)) {}
  std::uint64_t size() const override { return bytes_.size(); }
  void read(std::uint64_t offset, std::size_t n, void* dst) const override {
    if (n) std::memcpy(dst, bytes_.data() + offset, n);
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

// Reads fields in order; every read is checked against the end of the file first.
class Cursor {
 public:
  Cursor(const UboBtf::Source& s, const std::string& name) : s_(s), name_(name) {}

  std::uint64_t pos() const { return pos_; }
  std::uint64_t left() const { return s_.size() - pos_; }
  void need(std::uint64_t n, const std::string& what) const {
    if (n > left())
      throw Error(Error::Kind::kFormat,
                  fmt::format("{}: the file ends inside {} (at byte {}, {} bytes needed, {} "
                              "left); the file is incomplete: copy or download it again",
                              name_, what, pos_, n, left()));
  }
  template <class T>
  T get(const std::string& what) {
    need(sizeof(T), what);
    T v{};
    s_.read(pos_, sizeof(T), &v);
    pos_ += sizeof(T);
    return v;
  }
  std::string text(std::uint64_t n, const std::string& what) {
    need(n, what);
    std::string s(std::size_t(n), '\0');
    s_.read(pos_, s.size(), s.data());
    pos_ += n;
    return s;
  }
  void skip(std::uint64_t n, const std::string& what) {
    need(n, what);
    pos_ += n;
  }
  const std::string& name() const { return name_; }

 private:
  const UboBtf::Source& s_;
  std::string name_;
  std::uint64_t pos_ = 0;
};

Error format_error(const std::string& name, const std::string& text) {
  return Error(Error::Kind::kFormat, name + ": " + text);
}

std::string until_nul(const std::string& s) {
  return s.substr(0, std::min(s.find('\0'), s.size()));
}

// ---- the common header -----------------------------------------------------------------

void read_signature(Cursor& c, UboBtfHeader& h) {
  h.signature = c.text(10, "the signature (10 bytes)");
  if (h.signature == kDfmfSignature) {
    h.kind = UboKind::kDfmf;
  } else if (h.signature == kFmfSignature) {
    h.kind = UboKind::kFmf;
  } else {
    std::string shown;
    for (char ch : h.signature) shown += (ch >= 32 && ch < 127) ? ch : '?';
    throw format_error(c.name(),
                       fmt::format("the signature is '{}'{}; btfgmm reads the Bonn formats {} "
                                   "(UBO2014) and {}; give such a file",
                                   shown,
                                   shown.front() == '!' ? ", a Bonn format btfgmm does not read"
                                                        : ", not a Bonn BTF file",
                                   kDfmfSignature, kFmfSignature));
  }
}

// The metadata block: its size field counts itself and every field after it.
void read_metadata(Cursor& c, UboBtfHeader& h) {
  const std::uint64_t start = c.pos();
  const auto size = c.get<std::uint32_t>("the metadata's size");
  h.version = c.get<std::uint32_t>("the metadata's version");
  if (h.version < 1 || h.version > 4)
    throw format_error(c.name(), fmt::format("the metadata's version is {}; the Bonn readers "
                                             "know versions 1 to 4: is this a Bonn .btf file?",
                                             h.version));
  h.measurement_setup = until_nul(c.text(80, "the measurement setup (80 bytes)"));
  h.image_sensor = until_nul(c.text(80, "the image sensor (80 bytes)"));
  h.light_source = until_nul(c.text(80, "the light source (80 bytes)"));
  h.ppmm = c.get<float>("the pixels per millimetre");
  for (float& s : h.rgb_scale) s = c.get<float>("the RGB scale factors");
  if (h.version > 1) h.cosine_in_data = c.get<std::uint32_t>("the cosine flag") != 0;
  if (h.version > 2) h.xml = c.text(c.get<std::uint32_t>("the XML's length"), "the XML");
  h.channel_names = {"R", "G", "B"};
  if (h.version > 3) {
    const auto n = c.get<std::uint32_t>("the number of channels");
    if (n != 3)
      throw format_error(c.name(),
                         fmt::format("the file has {} channels; btfgmm reads 3-channel (RGB) "
                                     "files: convert the spectral data to RGB first",
                                     n));
    for (std::string& name : h.channel_names)
      name = c.text(c.get<std::uint32_t>("a channel name's length"), "a channel name");
  }
  if (c.pos() - start != size)
    throw format_error(c.name(), fmt::format("the metadata's size field says {} bytes but its "
                                             "version-{} fields take {}; the header is damaged",
                                             size, h.version, c.pos() - start));
}

Direction file_direction(float theta, float phi, const std::string& what, const Cursor& c) {
  constexpr double kDeg = 180.0 / std::numbers::pi;
  if (!std::isfinite(theta) || !std::isfinite(phi) || theta < -1e-4f ||
      theta > float(std::numbers::pi / 2 + 1e-4))
    throw format_error(c.name(), fmt::format("{} has the angles ({}, {}) radians; a direction "
                                             "of the upper hemisphere has theta in [0, pi/2] "
                                             "and a finite phi: the header is damaged",
                                             what, theta, phi));
  double p = std::fmod(double(phi) * kDeg, 360.0);
  if (p < 0) p += 360.0;
  if (p >= 360.0) p = 0.0;
  return {std::clamp(double(theta) * kDeg, 0.0, 90.0), p};
}

// The views, each with its light list; the Bonn readers keep the first view's lights and
// require every view to list as many.
void read_directions(Cursor& c, UboBtfHeader& h) {
  const auto nv = c.get<std::uint32_t>("the number of views");
  if (nv < 1 || nv > kMaxDirections)
    throw format_error(
        c.name(), fmt::format("the file lists {} views; expected 1 to {}", nv, kMaxDirections));
  std::vector<Direction> views, lights;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::string view = fmt::format("view {}", v);
    const auto theta = c.get<float>(view + "'s angles"), phi = c.get<float>(view + "'s angles");
    views.push_back(file_direction(theta, phi, view, c));
    const auto nl = c.get<std::uint32_t>(view + "'s number of lights");
    if (v == 0 && (nl < 1 || nl > kMaxDirections))
      throw format_error(
          c.name(), fmt::format("view 0 lists {} lights; expected 1 to {}", nl, kMaxDirections));
    if (v > 0 && nl != lights.size())
      throw format_error(c.name(), fmt::format("view {} lists {} lights but view 0 lists {}; "
                                               "btfgmm (as the Bonn readers) needs one light "
                                               "set for every view",
                                               v, nl, lights.size()));
    c.need(std::uint64_t(nl) * 8, view + "'s light directions");
    if (v > 0) {
      c.skip(std::uint64_t(nl) * 8, view + "'s light directions");
      continue;
    }
    for (std::uint32_t l = 0; l < nl; ++l) {
      const auto lt = c.get<float>("a light direction"), lp = c.get<float>("a light direction");
      lights.push_back(file_direction(lt, lp, fmt::format("light {} of view 0", l), c));
    }
  }
  h.views = DirectionSet(std::move(views));
  h.lights = DirectionSet(std::move(lights));
}

void read_size_and_rotations(Cursor& c, UboBtfHeader& h) {
  const auto w = c.get<std::uint32_t>("the width"), ht = c.get<std::uint32_t>("the height");
  if (w < 1 || ht < 1 || w > kMaxSide || ht > kMaxSide)
    throw format_error(c.name(), fmt::format("the images are {} x {} pixels; expected 1 to {} "
                                             "on each side",
                                             w, ht, kMaxSide));
  h.width = int(w);
  h.height = int(ht);
  if (h.signature.back() == 'R') {  // the rotations of the local frames, 3 x 3 floats each
    h.rotations = c.get<std::uint32_t>("the number of rotations");
    c.skip(std::uint64_t(h.rotations) * 36, "the rotations");
  }
}

// ---- the factor matrices ---------------------------------------------------------------

std::vector<float> read_finite(Cursor& c, const UboBtf::Source& s, std::uint64_t rows,
                               std::uint32_t columns, int scalar_bytes, const std::string& what) {
  const std::uint64_t count = rows * columns;
  c.need(count * std::uint64_t(scalar_bytes), what);
  limits::check_memory(double(count) * 4.0, fmt::format("{} of {}", what, c.name()),
                       "the file is larger than this machine can hold");
  std::vector<std::uint8_t> raw(std::size_t(count) * std::size_t(scalar_bytes));
  s.read(c.pos(), raw.size(), raw.data());
  c.skip(raw.size(), what);
  std::vector<float> out(static_cast<std::size_t>(count));
  detail::scalars_to_floats(raw.data(), out.size(), scalar_bytes, out.data());
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!std::isfinite(out[i]))
      throw format_error(c.name(), fmt::format("{} holds {} at row {}, component {}; the file "
                                               "is damaged",
                                               what, std::isnan(out[i]) ? "NaN" : "an infinity",
                                               i / columns, i % columns));
  return out;
}

// One matrix's sizes, S and U (read), and where its S x V lies (checked, skipped).
UboBtf::Matrix read_matrix(Cursor& c, const UboBtf::Source& s, const UboBtfHeader& h,
                           std::uint64_t expected_rows, const std::string& what,
                           bool scalar_first) {
  int scalar_bytes = h.scalar_bytes;
  if (scalar_first) scalar_bytes = c.get<std::uint8_t>(what + "'s scalar size");
  if (scalar_bytes != 2 && scalar_bytes != 4 && scalar_bytes != 8)
    throw format_error(c.name(), fmt::format("{}'s scalars are {} bytes; the format stores 2 "
                                             "(half), 4 or 8",
                                             what, scalar_bytes));
  UboBtf::Matrix m;
  m.components = c.get<std::uint32_t>(what + "'s number of components");
  m.rows = c.get<std::uint32_t>(what + "'s number of rows");
  m.columns = c.get<std::uint32_t>(what + "'s number of columns");
  const std::uint64_t pixels = std::uint64_t(h.width) * std::uint64_t(h.height);
  if (m.rows != expected_rows || m.columns != pixels)
    throw format_error(
        c.name(), fmt::format("{} is {} x {} but the header's {} lights x {} views{} and {} x {} "
                              "pixels make it {} x {}; the sections disagree: the file is damaged",
                              what, m.rows, m.columns, h.lights.size(), h.views.size(),
                              h.kind == UboKind::kFmf ? " x 3 channels" : "", h.width, h.height,
                              expected_rows, pixels));
  if (m.components < 1 || m.components > 65536)
    throw format_error(
        c.name(), fmt::format("{} has {} components; expected 1 to 65536", what, m.components));
  read_finite(c, s, m.components, 1, scalar_bytes, what + "'s S");
  m.u = read_finite(c, s, m.rows, m.components, scalar_bytes, what + "'s U");
  m.sxv_offset = c.pos();
  c.skip(pixels * m.components * std::uint64_t(scalar_bytes), what + "'s S x V");
  return m;
}

bool known_colour_model(std::int32_t m) {
  return m == 0 || m == 1 || m == 3 || m == 4 || (m >= 9 && m <= 12);
}

std::vector<UboBtf::Matrix> read_dfmf(Cursor& c, const UboBtf::Source& s, UboBtfHeader& h) {
  h.max_components = c.get<std::uint32_t>("the number of components");
  h.colour_model = c.get<std::int32_t>("the colour model");
  for (float& v : h.colour_mean) v = c.get<float>("the colour mean");
  for (float& v : h.colour_matrix) v = c.get<float>("the colour transformation matrix");
  if (!known_colour_model(h.colour_model))
    throw format_error(c.name(),
                       fmt::format("the colour model is {} ({}); btfgmm decodes the "
                                   "models 0, 1, 3, 4 and 9 to 12 as btflib numbers "
                                   "them",
                                   h.colour_model, ubo_colour_model_name(h.colour_model)));
  const auto finite = [](float v) { return std::isfinite(v); };
  if (!std::all_of(h.colour_mean.begin(), h.colour_mean.end(), finite) ||
      !std::all_of(h.colour_matrix.begin(), h.colour_matrix.end(), finite))
    throw format_error(c.name(),
                       "the colour mean or transformation matrix is not finite; the "
                       "file is damaged");
  std::vector<UboBtf::Matrix> out;
  const std::uint64_t pairs = std::uint64_t(h.lights.size()) * h.views.size();
  for (std::size_t ch = 0; ch < 3; ++ch) {
    out.push_back(read_matrix(c, s, h, pairs, fmt::format("channel {}", ch), true));
    h.components.push_back(out.back().components);
  }
  h.scalar_bytes = 2;
  return out;
}

std::vector<UboBtf::Matrix> read_fmf(Cursor& c, const UboBtf::Source& s, UboBtfHeader& h) {
  h.fmf_header_version = c.get<std::uint8_t>("the FMF header's version");
  if (h.fmf_header_version >= 3)
    throw format_error(c.name(), fmt::format("the FMF header's version is {}; the Bonn readers "
                                             "know versions 0 to 2",
                                             h.fmf_header_version));
  if (h.fmf_header_version >= 1)
    h.dynamic_range_reduction = c.get<std::uint32_t>("the dynamic-range reduction");
  if (h.fmf_header_version >= 2) {
    h.height_map_width = c.get<std::uint32_t>("the height map's size");
    h.height_map_height = c.get<std::uint32_t>("the height map's size");
    c.skip(std::uint64_t(h.height_map_width) * h.height_map_height * 2, "the height map");
  }
  h.max_components = c.get<std::uint32_t>("the number of components");
  h.scalar_bytes = c.get<std::uint8_t>("the scalar size");
  const std::uint64_t rows = std::uint64_t(h.lights.size()) * h.views.size() * 3;
  std::vector<UboBtf::Matrix> out;
  out.push_back(read_matrix(c, s, h, rows, "the matrix", false));
  h.components.push_back(out.back().components);
  return out;
}

}  // namespace

std::string ubo_colour_model_name(std::int32_t model) {
  switch (model) {
    case 0:
      return "RGB";
    case 1:
      return "YUV";
    case 2:
      return "Lab";
    case 3:
      return "PCA (matrix and mean)";
    case 4:
      return "YCoCg";
    case 5:
      return "spectral";
    case 6:
      return "spectral, linear";
    case 9:
      return "Ylog U V";
    case 10:
      return "Ylog Ulog Vlog";
    case 11:
      return "Ylog U/Y V/Y";
    case 12:
      return "log RGB";
    default:
      return "unknown";
  }
}

bool has_ubo_signature(std::span<const std::uint8_t> head) {
  if (head.size() < 4 || head[0] != '!') return false;
  const std::string s(head.begin() + 1,
                      head.begin() + std::ptrdiff_t(std::min<std::size_t>(head.size(), 5)));
  return s.rfind("DFMF", 0) == 0 || s.rfind("FMF", 0) == 0 || s.rfind("BDI", 0) == 0 ||
         s.rfind("PVF", 0) == 0;
}

bool is_ubo_btf_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  std::string ext = path.extension().string();
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return ext == ".btf" || has_ubo_signature(read_file_start(path, 16));
}

namespace {

void read_all(const std::shared_ptr<const UboBtf::Source>& source, const std::string& name,
              UboBtfHeader& h, std::vector<UboBtf::Matrix>& matrices) {
  Cursor c(*source, name);
  read_signature(c, h);
  read_metadata(c, h);
  read_directions(c, h);
  read_size_and_rotations(c, h);
  matrices = h.kind == UboKind::kDfmf ? read_dfmf(c, *source, h) : read_fmf(c, *source, h);
  if (c.left() != 0)
    throw format_error(name, fmt::format("{} bytes follow the last section (at byte {}); the "
                                         "sizes disagree with the file: it is damaged",
                                         c.left(), c.pos()));
  h.file_bytes = source->size();
}

}  // namespace

UboBtf UboBtf::open(const fs::path& path) {
  UboBtf b;
  b.name_ = path.string();
  b.source_ = std::make_shared<FileSource>(path);
  read_all(b.source_, b.name_, b.header_, b.matrices_);
  return b;
}

UboBtf UboBtf::from_bytes(std::vector<std::uint8_t> bytes, const std::string& name) {
  UboBtf b;
  b.name_ = name;
  b.source_ = std::make_shared<MemorySource>(std::move(bytes));
  read_all(b.source_, b.name_, b.header_, b.matrices_);
  return b;
}

}  // namespace btfgmm
