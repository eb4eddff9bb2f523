// Image and data-set I/O: readers against the UTIA writer, Bonn folders and zips, tiles, and
// one test per malformed input (each must throw btfgmm::Error naming the file at fault).
#include <gtest/gtest.h>
#include <stb/stb_image_write.h>
#include <unistd.h>
#include <zip.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/measure/tile.hpp"

namespace fs = std::filesystem;
using btfgmm::Btf;
using btfgmm::BtfSource;
using btfgmm::Direction;
using btfgmm::DirectionSet;
using btfgmm::Error;
using btfgmm::ImageFormat;
using btfgmm::Layout;
using btfgmm::SampleFormat;
using btfgmm::Tile;

namespace {

// A fresh folder per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ =
        fs::temp_directory_path() / ("btfgmm_io_" + std::string(info ? info->name() : "x") + "_" +
                                     std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& rel) const { return path_ / rel; }

 private:
  fs::path path_;
};

std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::uint64_t hash(std::size_t l, std::size_t v, int x, int y, int c) {
  return mix(mix(mix(mix(mix(l) + v) + std::uint64_t(x)) + std::uint64_t(y)) + std::uint64_t(c));
}

// Whole numbers 0..255.
void fill_ldr(Btf& b) {
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (std::size_t v = 0; v < b.views().size(); ++v)
      for (int y = 0; y < b.height(); ++y)
        for (int x = 0; x < b.width(); ++x)
          for (int c = 0; c < 3; ++c) b.at(l, v, x, y, c) = float(hash(l, v, x, y, c) % 256);
}

// Arbitrary floats: negative, tiny, huge.
void fill_hdr(Btf& b) {
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (std::size_t v = 0; v < b.views().size(); ++v)
      for (int y = 0; y < b.height(); ++y)
        for (int x = 0; x < b.width(); ++x)
          for (int c = 0; c < 3; ++c) {
            const std::uint64_t h = hash(l, v, x, y, c);
            const double mant = 0.5 + double(h & 0xffff) / 131072.0;
            const int e = int((h >> 16) % 61) - 30;
            const double sign = ((h >> 24) & 1) ? -1.0 : 1.0;
            b.at(l, v, x, y, c) = float(sign * std::ldexp(mant, e));
          }
}

Btf make_btf(SampleFormat f, int w = 12, int h = 10,
             DirectionSet lights = DirectionSet::rings({{0, 1}, {45, 4}}),
             DirectionSet views = DirectionSet::rings({{0, 1}, {30, 2}})) {
  Btf b(std::move(lights), std::move(views), w, h, f);
  if (f == SampleFormat::kHdr)
    fill_hdr(b);
  else
    fill_ldr(b);
  return b;
}

void expect_same(const Btf& a, const Btf& b) {
  ASSERT_EQ(a.lights().size(), b.lights().size());
  ASSERT_EQ(a.views().size(), b.views().size());
  for (std::size_t i = 0; i < a.lights().size(); ++i) {
    EXPECT_EQ(a.lights()[i].theta_deg, b.lights()[i].theta_deg) << "light " << i;
    EXPECT_EQ(a.lights()[i].phi_deg, b.lights()[i].phi_deg) << "light " << i;
  }
  for (std::size_t i = 0; i < a.views().size(); ++i) {
    EXPECT_EQ(a.views()[i].theta_deg, b.views()[i].theta_deg) << "view " << i;
    EXPECT_EQ(a.views()[i].phi_deg, b.views()[i].phi_deg) << "view " << i;
  }
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  EXPECT_EQ(a.format(), b.format());
  ASSERT_EQ(a.data().size(), b.data().size());
  std::size_t bad = 0;
  for (std::size_t i = 0; i < a.data().size(); ++i)
    if (a.data()[i] != b.data()[i] && ++bad <= 5)
      ADD_FAILURE() << "float " << i << ": " << a.data()[i] << " != " << b.data()[i];
  EXPECT_EQ(bad, 0u);
}

std::vector<std::uint8_t> file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void put_file(const fs::path& p, const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// The Error thrown by f (failing the test if none), for checks on kind and message.
Error error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw a non-btfgmm exception: " << e.what();
    return Error(Error::Kind::kIo, "");
  }
  ADD_FAILURE() << "did not throw";
  return Error(Error::Kind::kIo, "");
}

#define EXPECT_ERROR(expr, kind_, ...)                                                 \
  do {                                                                                 \
    const Error err_ = error_of([&] { (void)(expr); });                                \
    EXPECT_EQ(err_.kind(), kind_) << err_.what();                                      \
    for (const std::string& needle_ : std::initializer_list<std::string>{__VA_ARGS__}) \
      EXPECT_NE(std::string(err_.what()).find(needle_), std::string::npos)             \
          << "message lacks '" << needle_ << "': " << err_.what();                     \
  } while (0)

std::vector<std::uint8_t> encode_png8(int w, int h, int comp, const std::vector<std::uint8_t>& px) {
  std::vector<std::uint8_t> out;
  stbi_write_png_to_func(
      [](void* ctx, void* data, int size) {
        auto* o = static_cast<std::vector<std::uint8_t>*>(ctx);
        o->insert(o->end(), static_cast<std::uint8_t*>(data),
                  static_cast<std::uint8_t*>(data) + size);
      },
      &out, w, h, comp, px.data(), w * comp);
  return out;
}

std::vector<std::uint8_t> encode_jpeg(int w, int h, const std::vector<std::uint8_t>& rgb) {
  std::vector<std::uint8_t> out;
  stbi_write_jpg_to_func(
      [](void* ctx, void* data, int size) {
        auto* o = static_cast<std::vector<std::uint8_t>*>(ctx);
        o->insert(o->end(), static_cast<std::uint8_t*>(data),
                  static_cast<std::uint8_t*>(data) + size);
      },
      &out, w, h, 3, rgb.data(), 100);
  return out;
}

// A 16-bit RGB PNG with stored (uncompressed) deflate blocks; stb writes only 8-bit.
std::vector<std::uint8_t> encode_png16(int w, int h, const std::vector<std::uint16_t>& rgb) {
  auto crc32 = [](const std::uint8_t* p, std::size_t n) {
    std::uint32_t c = 0xffffffffu;
    for (std::size_t i = 0; i < n; ++i) {
      c ^= p[i];
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
  };
  auto be32 = [](std::vector<std::uint8_t>& o, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) o.push_back(std::uint8_t(v >> s));
  };
  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  auto chunk = [&](const char* type, const std::vector<std::uint8_t>& data) {
    be32(out, std::uint32_t(data.size()));
    std::vector<std::uint8_t> td(type, type + 4);
    td.insert(td.end(), data.begin(), data.end());
    out.insert(out.end(), td.begin(), td.end());
    be32(out, crc32(td.data(), td.size()));
  };
  std::vector<std::uint8_t> ihdr;
  be32(ihdr, std::uint32_t(w));
  be32(ihdr, std::uint32_t(h));
  ihdr.insert(ihdr.end(), {16, 2, 0, 0, 0});
  chunk("IHDR", ihdr);
  std::vector<std::uint8_t> raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);
    for (int i = 0; i < w * 3; ++i) {
      const std::uint16_t v = rgb[std::size_t(y) * std::size_t(w) * 3 + std::size_t(i)];
      raw.push_back(std::uint8_t(v >> 8));
      raw.push_back(std::uint8_t(v & 0xff));
    }
  }
  std::vector<std::uint8_t> z = {0x78, 0x01};
  for (std::size_t pos = 0; pos < raw.size();) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - pos);
    z.push_back(pos + n == raw.size() ? 1 : 0);
    z.push_back(std::uint8_t(n & 0xff));
    z.push_back(std::uint8_t(n >> 8));
    z.push_back(std::uint8_t(~n & 0xff));
    z.push_back(std::uint8_t((~n >> 8) & 0xff));
    z.insert(z.end(), raw.begin() + std::ptrdiff_t(pos), raw.begin() + std::ptrdiff_t(pos + n));
    pos += n;
  }
  std::uint32_t a = 1, b = 0;
  for (std::uint8_t c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  be32(z, (b << 16) | a);
  chunk("IDAT", z);
  chunk("IEND", {});
  return out;
}

// Every file under `root`, relative, sorted.
std::vector<std::string> list_files(const fs::path& root) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) out.push_back(fs::relative(e.path(), root).generic_string());
  std::sort(out.begin(), out.end());
  return out;
}

// Bonn-style names: "00008 tl000 pl000 tv030 pv030.png", separators alternating ' ' / '_'.
std::string bonn_name(const Btf& b, std::size_t l, std::size_t v, const char* ext) {
  const std::string stem = btfgmm::utia_image_stem(b.lights()[l], b.views()[v]);
  std::string name = std::string(5 - std::to_string(b.image_index(l, v)).size(), '0') +
                     std::to_string(b.image_index(l, v)) + "_" + stem;
  if ((l + v) % 2 == 0)
    for (char& c : name)
      if (c == '_') c = ' ';
  return name + ext;
}

std::string view_folder(const Direction& v) {
  const std::string stem = btfgmm::utia_image_stem({0, 0}, v);
  return stem.substr(stem.find("tv"));
}

std::vector<std::uint8_t> to_bytes(const float* rgb, std::size_t n) {
  std::vector<std::uint8_t> px(n);
  for (std::size_t i = 0; i < n; ++i) px[i] = std::uint8_t(rgb[i]);
  return px;
}

// A zip of `entries` (name -> bytes), written with libzip.
void make_zip(const fs::path& path,
              const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& entries,
              const std::vector<std::string>& dirs = {}) {
  int code = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
  ASSERT_NE(z, nullptr) << code;
  for (const auto& d : dirs) ASSERT_GE(zip_dir_add(z, d.c_str(), ZIP_FL_ENC_UTF_8), 0);
  for (const auto& [name, bytes] : entries) {
    zip_source_t* s = zip_source_buffer(z, bytes.data(), bytes.size(), 0);
    ASSERT_NE(s, nullptr);
    ASSERT_GE(zip_file_add(z, name.c_str(), s, ZIP_FL_ENC_UTF_8), 0) << zip_strerror(z);
  }
  ASSERT_EQ(zip_close(z), 0);
}

}  // namespace

// ---- names -------------------------------------------------------------------------------

TEST(Name, ParsesUtia) {
  const auto n = btfgmm::parse_image_name("tl015_pl060_tv030_pv330.png");
  EXPECT_EQ(n.light.theta_deg, 15.0);
  EXPECT_EQ(n.light.phi_deg, 60.0);
  EXPECT_EQ(n.view.theta_deg, 30.0);
  EXPECT_EQ(n.view.phi_deg, 330.0);
  EXPECT_FALSE(n.index.has_value());
}

TEST(Name, ParsesFractionsAndCase) {
  const auto n = btfgmm::parse_image_name("TL023.5_Pl007.5_tv041.25_PV200.EXR");
  EXPECT_EQ(n.light.theta_deg, 23.5);
  EXPECT_EQ(n.light.phi_deg, 7.5);
  EXPECT_EQ(n.view.theta_deg, 41.25);
  EXPECT_EQ(n.view.phi_deg, 200.0);
  // No extension: the fraction of the last angle stays.
  EXPECT_EQ(btfgmm::parse_image_name("tl000_pl000_tv000_pv022.5").view.phi_deg, 22.5);
}

TEST(Name, ParsesBonnIndexAndSeparators) {
  for (const char* name : {"00008 tl000 pl000 tv030 pv030.jpg", "00008_tl000_pl000_tv030_pv030.jpg",
                           "00008  tl000_pl000 __tv030 pv030.jpeg"}) {
    const auto n = btfgmm::parse_image_name(name);
    ASSERT_TRUE(n.index.has_value()) << name;
    EXPECT_EQ(*n.index, 8) << name;
    EXPECT_EQ(n.light.theta_deg, 0.0);
    EXPECT_EQ(n.view.theta_deg, 30.0) << name;
    EXPECT_EQ(n.view.phi_deg, 30.0) << name;
  }
}

TEST(Name, RejectsBadNames) {
  for (const char* name : {"foo.png", "tl000_pl000_tv000.png", "tl000_pl000_tv000_pv000_x.png",
                           "tl0a0_pl000_tv000_pv000.png", "tl.5_pl000_tv000_pv000.png",
                           "tl000_pl000_pv000_tv000.png", "tl5._pl000_tv000_pv000.png",
                           "x00 tl000 pl000 tv0 pv0.jpg", "tl-10_pl000_tv000_pv000.png", ""}) {
    EXPECT_ERROR(btfgmm::parse_image_name(name), Error::Kind::kFormat, std::string(name),
                 "tlTTT_plPPP_tvTTT_pvPPP");
  }
}

TEST(Name, RejectsAnglesOutOfRange) {
  EXPECT_ERROR(btfgmm::parse_image_name("tl095_pl000_tv000_pv000.png"), Error::Kind::kFormat,
               "tl095_pl000_tv000_pv000.png", "[0, 90]");
  EXPECT_ERROR(btfgmm::parse_image_name("tl000_pl000_tv090.5_pv000.png"), Error::Kind::kFormat,
               "tv090.5");
  EXPECT_ERROR(btfgmm::parse_image_name("tl000_pl360_tv000_pv000.png"), Error::Kind::kFormat,
               "pl360", "[0, 360)");
  EXPECT_NO_THROW(btfgmm::parse_image_name("tl090_pl359.9_tv090_pv000.png"));
}

TEST(Name, UtiaStemRoundTrips) {
  EXPECT_EQ(btfgmm::utia_image_stem({0, 0}, {30, 60}), "tl000_pl000_tv030_pv060");
  EXPECT_EQ(btfgmm::utia_image_stem({23.5, 7.5}, {41.25, 200}), "tl023.5_pl007.5_tv041.25_pv200");
  EXPECT_EQ(btfgmm::utia_image_stem({0.1, 12.345}, {90, 359.999}),
            "tl000.1_pl012.345_tv090_pv359.999");
  for (const Direction d : {Direction{0.1, 12.345}, Direction{89.9, 0.125}, Direction{7, 300.5}}) {
    const auto n = btfgmm::parse_image_name(btfgmm::utia_image_stem(d, d) + ".png");
    EXPECT_EQ(n.light.theta_deg, d.theta_deg);
    EXPECT_EQ(n.light.phi_deg, d.phi_deg);
    EXPECT_EQ(n.view.theta_deg, d.theta_deg);
    EXPECT_EQ(n.view.phi_deg, d.phi_deg);
  }
}

// ---- single images ------------------------------------------------------------------------

TEST(Image, FormatDetection) {
  using btfgmm::image_format_from_bytes;
  using btfgmm::image_format_from_name;
  EXPECT_EQ(image_format_from_name("a/b.PNG"), ImageFormat::kPng);
  EXPECT_EQ(image_format_from_name("x.jpeg"), ImageFormat::kJpeg);
  EXPECT_EQ(image_format_from_name("x.Jpg"), ImageFormat::kJpeg);
  EXPECT_EQ(image_format_from_name("x.exr"), ImageFormat::kExr);
  EXPECT_FALSE(image_format_from_name("readme.txt").has_value());
  EXPECT_FALSE(image_format_from_name("png").has_value());
  const std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0};
  const std::vector<std::uint8_t> jpg = {0xff, 0xd8, 0xff, 0xe0};
  const std::vector<std::uint8_t> exr = {0x76, 0x2f, 0x31, 0x01, 2};
  const std::vector<std::uint8_t> junk = {0x89, 'P', 'N', 'G'};
  EXPECT_EQ(image_format_from_bytes(png), ImageFormat::kPng);
  EXPECT_EQ(image_format_from_bytes(jpg), ImageFormat::kJpeg);
  EXPECT_EQ(image_format_from_bytes(exr), ImageFormat::kExr);
  EXPECT_FALSE(image_format_from_bytes(junk).has_value());
  EXPECT_FALSE(image_format_from_bytes({}).has_value());
}

TEST(Image, PngRoundTripIsExact) {
  TempDir dir;
  const int w = 9, h = 7;
  std::vector<float> rgb(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(mix(i) % 256);
  rgb[0] = -3.0f;   // clamped to 0
  rgb[1] = 300.0f;  // clamped to 255
  rgb[2] = 7.4f;    // rounded to 7
  btfgmm::write_png(dir / "a.png", w, h, rgb);
  const auto img = btfgmm::read_image(dir / "a.png");
  EXPECT_EQ(img.width, w);
  EXPECT_EQ(img.height, h);
  EXPECT_EQ(img.format, SampleFormat::kLdr8);
  rgb[0] = 0.0f;
  rgb[1] = 255.0f;
  rgb[2] = 7.0f;
  EXPECT_EQ(img.rgb, rgb);
  const auto hdr = btfgmm::read_image_header(dir / "a.png");
  EXPECT_EQ(hdr.width, w);
  EXPECT_EQ(hdr.height, h);
  EXPECT_EQ(hdr.format, SampleFormat::kLdr8);
  // No temporary file is left behind.
  EXPECT_EQ(list_files(dir.path()), std::vector<std::string>{"a.png"});
}

TEST(Image, GreyAndRgbaBecomeRgb) {
  const int w = 4, h = 3;
  std::vector<std::uint8_t> grey(std::size_t(w * h)), rgba(std::size_t(w * h * 4));
  for (std::size_t i = 0; i < grey.size(); ++i) grey[i] = std::uint8_t(i * 20);
  for (std::size_t i = 0; i < rgba.size(); ++i) rgba[i] = std::uint8_t(i * 5);
  const auto g = btfgmm::decode_image(encode_png8(w, h, 1, grey), "grey.png");
  ASSERT_EQ(g.rgb.size(), std::size_t(w * h * 3));
  for (std::size_t i = 0; i < grey.size(); ++i)
    for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(g.rgb[i * 3 + c], float(grey[i]));
  const auto a = btfgmm::decode_image(encode_png8(w, h, 4, rgba), "rgba.png");
  ASSERT_EQ(a.rgb.size(), std::size_t(w * h * 3));
  for (std::size_t i = 0; i < std::size_t(w * h); ++i)
    for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(a.rgb[i * 3 + c], float(rgba[i * 4 + c]));
}

TEST(Image, Png16IsScaledTo255) {
  const int w = 5, h = 4;
  std::vector<std::uint16_t> px(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = std::uint16_t(mix(i) & 0xffff);
  px[0] = 0;
  px[1] = 65535;
  px[2] = 257 * 100;
  const auto bytes = encode_png16(w, h, px);
  const auto hdr = btfgmm::decode_image_header(bytes, "deep.png");
  EXPECT_EQ(hdr.format, SampleFormat::kLdr16);
  const auto img = btfgmm::decode_image(bytes, "deep.png");
  EXPECT_EQ(img.format, SampleFormat::kLdr16);
  ASSERT_EQ(img.rgb.size(), px.size());
  EXPECT_EQ(img.rgb[0], 0.0f);
  EXPECT_EQ(img.rgb[1], 255.0f);
  EXPECT_EQ(img.rgb[2], 100.0f);
  for (std::size_t i = 0; i < px.size(); ++i) EXPECT_EQ(img.rgb[i], float(px[i]) / 257.0f);
}

TEST(Image, JpegDecodes) {
  TempDir dir;
  const int w = 16, h = 8;
  std::vector<std::uint8_t> rgb(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = std::uint8_t(100 + (i % 3) * 40);
  put_file(dir / "a.jpg", encode_jpeg(w, h, rgb));
  const auto hdr = btfgmm::read_image_header(dir / "a.jpg");
  EXPECT_EQ(hdr.width, w);
  EXPECT_EQ(hdr.height, h);
  EXPECT_EQ(hdr.format, SampleFormat::kLdr8);
  const auto img = btfgmm::read_image(dir / "a.jpg");
  ASSERT_EQ(img.rgb.size(), rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    EXPECT_NEAR(img.rgb[i], rgb[i], 3.0);
    EXPECT_EQ(img.rgb[i], std::round(img.rgb[i]));
  }
}

TEST(Image, ExrRoundTripIsExact) {
  TempDir dir;
  const int w = 6, h = 5;
  std::vector<float> rgb(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i)
    rgb[i] = float((i % 2 ? -1.0 : 1.0) *
                   std::ldexp(1.0 + double(mix(i) % 1000) / 999.0, int(mix(i + 7) % 80) - 40));
  rgb[3] = 0.0f;
  rgb[4] = 1e30f;
  rgb[5] = std::numeric_limits<float>::denorm_min();
  btfgmm::write_exr(dir / "a.exr", w, h, rgb);
  const auto img = btfgmm::read_image(dir / "a.exr");
  EXPECT_EQ(img.format, SampleFormat::kHdr);
  EXPECT_EQ(img.width, w);
  EXPECT_EQ(img.height, h);
  EXPECT_EQ(img.rgb, rgb);
  const auto hdr = btfgmm::read_image_header(dir / "a.exr");
  EXPECT_EQ(hdr.width, w);
  EXPECT_EQ(hdr.height, h);
  EXPECT_EQ(hdr.format, SampleFormat::kHdr);
  EXPECT_EQ(list_files(dir.path()), std::vector<std::string>{"a.exr"});
}

TEST(Image, RowsKeepOnlyTheTile) {
  TempDir dir;
  const int w = 11, h = 9;
  std::vector<float> rgb(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(mix(i) % 256);
  btfgmm::write_png(dir / "a.png", w, h, rgb);
  btfgmm::write_exr(dir / "a.exr", w, h, rgb);
  const Tile t{.x = 3, .y = 2, .width = 5, .height = 4};
  for (const char* name : {"a.png", "a.exr"}) {
    const auto img = btfgmm::read_image(dir / name, t);
    ASSERT_EQ(img.width, t.width) << name;
    ASSERT_EQ(img.height, t.height) << name;
    for (int y = 0; y < t.height; ++y)
      for (int x = 0; x < t.width; ++x)
        for (int c = 0; c < 3; ++c)
          EXPECT_EQ(img.rgb[std::size_t((y * t.width + x) * 3 + c)],
                    rgb[std::size_t(((y + t.y) * w + x + t.x) * 3 + c)])
              << name;
    EXPECT_ERROR(btfgmm::read_image(dir / name, Tile{.x = 8, .y = 0, .width = 4, .height = 4}),
                 Error::Kind::kArgument, (dir / name).string(), "11x9");
    EXPECT_ERROR(btfgmm::read_image(dir / name, Tile{.x = 0, .y = -1, .width = 4, .height = 4}),
                 Error::Kind::kArgument, (dir / name).string(), "11x9");
  }
}

TEST(Image, LargeFileHeaderAndTruncation) {
  // Over 64 KiB, so read_image_header reads a prefix and the file's end.
  TempDir dir;
  const int w = 200, h = 200;
  std::vector<float> rgb(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(mix(i) % 256);
  btfgmm::write_png(dir / "big.png", w, h, rgb);
  auto bytes = file_bytes(dir / "big.png");
  ASSERT_GT(bytes.size(), 70000u);
  const auto hdr = btfgmm::read_image_header(dir / "big.png");
  EXPECT_EQ(hdr.width, w);
  EXPECT_EQ(hdr.height, h);
  bytes.resize(bytes.size() - 5000);
  put_file(dir / "cut.png", bytes);
  EXPECT_ERROR(btfgmm::read_image_header(dir / "cut.png"), Error::Kind::kFormat,
               (dir / "cut.png").string(), "truncated");
  EXPECT_ERROR(btfgmm::read_image(dir / "cut.png"), Error::Kind::kFormat,
               (dir / "cut.png").string());
  // The same for OpenEXR: the header comes from the first 64 KiB; a cut file fails to load.
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(mix(i)) * 1e-10f;
  btfgmm::write_exr(dir / "big.exr", w, h, rgb);
  auto exr = file_bytes(dir / "big.exr");
  ASSERT_GT(exr.size(), 70000u);
  const auto exr_hdr = btfgmm::read_image_header(dir / "big.exr");
  EXPECT_EQ(exr_hdr.width, w);
  EXPECT_EQ(exr_hdr.height, h);
  EXPECT_EQ(exr_hdr.format, SampleFormat::kHdr);
  EXPECT_EQ(btfgmm::read_image(dir / "big.exr").rgb, rgb);
  exr.resize(exr.size() - 5000);
  put_file(dir / "cut.exr", exr);
  EXPECT_ERROR(btfgmm::read_image(dir / "cut.exr"), Error::Kind::kFormat,
               (dir / "cut.exr").string());
}

TEST(Image, TruncatedFilesAreErrors) {
  TempDir dir;
  const int w = 12, h = 12;
  std::vector<float> rgb(std::size_t(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(mix(i) % 256);
  btfgmm::write_png(dir / "a.png", w, h, rgb);
  btfgmm::write_exr(dir / "a.exr", w, h, rgb);
  std::vector<std::uint8_t> rgb8(rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb8[i] = std::uint8_t(rgb[i]);
  put_file(dir / "a.jpg", encode_jpeg(w, h, rgb8));
  for (const char* name : {"a.png", "a.jpg", "a.exr"}) {
    const auto full = file_bytes(dir / name);
    // Cut at several points, from inside the header to just before the end.
    for (const std::size_t keep :
         {std::size_t(5), std::size_t(30), full.size() / 2, full.size() - 2}) {
      const std::vector<std::uint8_t> cut(full.begin(), full.begin() + std::ptrdiff_t(keep));
      const std::string cut_name = std::string("cut_") + std::to_string(keep) + "_" + name;
      EXPECT_ERROR(btfgmm::decode_image(cut, cut_name), Error::Kind::kFormat, cut_name);
    }
  }
}

TEST(Image, ContentsMustMatchTheName) {
  const int w = 4, h = 4;
  const std::vector<std::uint8_t> rgb(std::size_t(w * h * 3), 77);
  const auto jpeg = encode_jpeg(w, h, rgb);
  EXPECT_ERROR(btfgmm::decode_image(jpeg, "dir/x.png"), Error::Kind::kFormat, "dir/x.png",
               "holds JPEG data", ".jpg");
  EXPECT_ERROR(btfgmm::decode_image_header(jpeg, "x.exr"), Error::Kind::kFormat, "x.exr", "JPEG");
  EXPECT_NO_THROW(btfgmm::decode_image(jpeg, "x.JPEG"));
  const std::vector<std::uint8_t> junk = {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd'};
  EXPECT_ERROR(btfgmm::decode_image(junk, "junk.png"), Error::Kind::kFormat, "junk.png");
  EXPECT_ERROR(btfgmm::decode_image({}, "empty.png"), Error::Kind::kFormat, "empty.png");
  // PNG magic followed by garbage.
  std::vector<std::uint8_t> fake = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  for (int i = 0; i < 200; ++i) fake.push_back(std::uint8_t(mix(std::uint64_t(i))));
  EXPECT_ERROR(btfgmm::decode_image(fake, "fake.png"), Error::Kind::kFormat, "fake.png");
  EXPECT_ERROR(btfgmm::decode_image_header(fake, "fake.png"), Error::Kind::kFormat, "fake.png");
  std::vector<std::uint8_t> fake_exr = {0x76, 0x2f, 0x31, 0x01};
  for (int i = 0; i < 200; ++i) fake_exr.push_back(std::uint8_t(mix(std::uint64_t(i))));
  EXPECT_ERROR(btfgmm::decode_image(fake_exr, "fake.exr"), Error::Kind::kFormat, "fake.exr");
  EXPECT_ERROR(btfgmm::decode_image_header(fake_exr, "fake.exr"), Error::Kind::kFormat, "fake.exr");
}

TEST(Image, ExrNonFiniteIsAnError) {
  TempDir dir;
  const int w = 5, h = 4;
  std::vector<float> rgb(std::size_t(w * h * 3), 0.5f);
  rgb[std::size_t((2 * w + 3) * 3 + 1)] = std::numeric_limits<float>::quiet_NaN();
  btfgmm::write_exr(dir / "nan.exr", w, h, rgb);
  EXPECT_ERROR(btfgmm::read_image(dir / "nan.exr"), Error::Kind::kFormat,
               (dir / "nan.exr").string(), "x=3 y=2", "channel G", "non-finite");
  // A tile that misses the bad pixel reads fine.
  EXPECT_NO_THROW(
      btfgmm::read_image(dir / "nan.exr", Tile{.x = 0, .y = 0, .width = 2, .height = 4}));
  rgb[std::size_t((2 * w + 3) * 3 + 1)] = 0.5f;
  rgb[0] = -std::numeric_limits<float>::infinity();
  btfgmm::write_exr(dir / "inf.exr", w, h, rgb);
  EXPECT_ERROR(btfgmm::read_image(dir / "inf.exr"), Error::Kind::kFormat,
               (dir / "inf.exr").string(), "x=0 y=0", "channel R");
}

TEST(Image, FileErrorsNameThePath) {
  TempDir dir;
  const std::vector<float> rgb(3 * 4, 1.0f);
  EXPECT_ERROR(btfgmm::read_image(dir / "missing.png"), Error::Kind::kIo,
               (dir / "missing.png").string(), "No such file");
  EXPECT_ERROR(btfgmm::read_image_header(dir / "missing.exr"), Error::Kind::kIo,
               (dir / "missing.exr").string());
  EXPECT_ERROR(btfgmm::write_png(dir / "no/such/folder/a.png", 2, 2, rgb), Error::Kind::kIo,
               (dir / "no/such/folder/a.png").string(), "does not exist");
  EXPECT_ERROR(btfgmm::write_exr(dir / "nofolder/a.exr", 2, 2, rgb), Error::Kind::kIo, "nofolder",
               "does not exist");
  EXPECT_ERROR(btfgmm::write_png(dir / "a.png", 3, 2, rgb), Error::Kind::kArgument, "a.png");
  btfgmm::Image img{.width = 2, .height = 2, .format = SampleFormat::kLdr8, .rgb = rgb};
  EXPECT_ERROR(btfgmm::write_image(dir / "a.tif", img), Error::Kind::kArgument, "a.tif", ".png",
               ".jpg", ".exr");
  btfgmm::write_image(dir / "b.exr", img);
  btfgmm::write_image(dir / "b.png", img);
  EXPECT_EQ(btfgmm::read_image(dir / "b.exr").rgb, rgb);
  EXPECT_EQ(btfgmm::read_image(dir / "b.png").rgb, rgb);
  EXPECT_EQ(list_files(dir.path()), (std::vector<std::string>{"b.exr", "b.png"}));
}

// ---- data sets ----------------------------------------------------------------------------

TEST(Dataset, NestedPngRoundTrip) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kLdr8);
  btfgmm::write_utia(b, dir.path());
  EXPECT_TRUE(fs::exists(dir / "tv030_pv180/tl045_pl270_tv030_pv180.png"));
  const auto src = BtfSource::open(dir.path());
  const auto& info = src.info();
  EXPECT_EQ(info.layout, Layout::kUtiaNested);
  EXPECT_EQ(info.width, 12);
  EXPECT_EQ(info.height, 10);
  EXPECT_EQ(info.format, SampleFormat::kLdr8);
  EXPECT_EQ(info.image_format, ImageFormat::kPng);
  EXPECT_EQ(info.ignored_files, 0u);
  EXPECT_TRUE(info.lights == b.lights());
  EXPECT_TRUE(info.views == b.views());
  std::uint64_t total = 0;
  for (const auto& f : list_files(dir.path())) total += fs::file_size(dir / f);
  EXPECT_EQ(info.file_bytes, total);
  EXPECT_EQ(src.image_name(0, 0), "tv000_pv000/tl000_pl000_tv000_pv000.png");
  EXPECT_EQ(src.image_name(2, 1), "tv030_pv000/tl045_pl090_tv030_pv000.png");
  const Btf loaded = src.load();
  expect_same(loaded, b);
  EXPECT_EQ(loaded.origin().width, 12);
  EXPECT_EQ(loaded.origin().height, 10);
  EXPECT_EQ(list_files(dir.path()).size(), b.image_count());  // no temporary files left
}

TEST(Dataset, NestedExrRoundTrip) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kHdr, 8, 6);
  btfgmm::write_utia(b, dir.path());
  EXPECT_TRUE(fs::exists(dir / "tv000_pv000/tl000_pl000_tv000_pv000.exr"));
  const auto src = BtfSource::open(dir.path());
  EXPECT_EQ(src.info().format, SampleFormat::kHdr);
  EXPECT_EQ(src.info().image_format, ImageFormat::kExr);
  expect_same(src.load(), b);
  // Forced PNG for HDR data writes rounded, clamped levels.
  TempDir png;
  btfgmm::write_utia(b, png.path(), ImageFormat::kPng);
  const Btf p = BtfSource::open(png.path()).load();
  EXPECT_EQ(p.format(), SampleFormat::kLdr8);
  for (std::size_t i = 0; i < p.data().size(); ++i)
    EXPECT_EQ(p.data()[i], std::clamp(std::round(b.data()[i]), 0.0f, 255.0f));
}

TEST(Dataset, FlatFolderRoundTrip) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kLdr8, 8, 8);
  btfgmm::write_utia(b, dir.path());
  for (const auto& f : list_files(dir.path())) fs::rename(dir / f, dir / fs::path(f).filename());
  for (const auto& v : b.views()) fs::remove(dir / view_folder(v));
  put_file(dir / "README.txt", {'h', 'i'});
  const auto src = BtfSource::open(dir.path());
  EXPECT_EQ(src.info().layout, Layout::kUtiaFlat);
  EXPECT_EQ(src.info().ignored_files, 1u);
  EXPECT_EQ(src.image_name(0, 0), "tl000_pl000_tv000_pv000.png");
  expect_same(src.load(), b);
}

TEST(Dataset, FractionalAnglesRoundTrip) {
  TempDir dir;
  const Btf b =
      make_btf(SampleFormat::kLdr8, 8, 8, DirectionSet({{0, 0}, {23.5, 7.5}, {41.25, 200}}),
               DirectionSet({{0, 0}, {12.5, 90}}));
  btfgmm::write_utia(b, dir.path());
  EXPECT_TRUE(fs::exists(dir / "tv012.5_pv090/tl041.25_pl200_tv012.5_pv090.png"));
  const auto src = BtfSource::open(dir.path());
  EXPECT_EQ(src.info().layout, Layout::kUtiaNested);
  expect_same(src.load(), b);
  // And the same as a HDR set.
  TempDir hdr;
  const Btf h = make_btf(SampleFormat::kHdr, 4, 4, b.lights(), b.views());
  btfgmm::write_utia(h, hdr.path());
  expect_same(BtfSource::open(hdr.path()).load(), h);
}

namespace {

// An 8 x 8 BTF as Bonn-named PNGs in `folder`; returns the same files as zip entries under
// material/<view folder>/.
std::vector<std::pair<std::string, std::vector<std::uint8_t>>> write_bonn_folder(
    const Btf& b, const fs::path& folder) {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> entries;
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (std::size_t v = 0; v < b.views().size(); ++v) {
      const auto png = encode_png8(8, 8, 3, to_bytes(b.image(l, v), b.image_floats()));
      const std::string name = bonn_name(b, l, v, ".png");
      put_file(folder / name, png);
      entries.emplace_back("material/" + view_folder(b.views()[v]) + "/" + name, png);
    }
  return entries;
}

}  // namespace

TEST(Dataset, BonnFolderAndZipReadTheSameValues) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kLdr8, 8, 8);
  auto entries = write_bonn_folder(b, dir / "bonn");
  entries.emplace_back("material/README.txt", std::vector<std::uint8_t>{'x'});
  entries.emplace_back("__MACOSX/material/._00000 tl000 pl000 tv000 pv000.png",
                       std::vector<std::uint8_t>{'y'});
  const auto folder = BtfSource::open(dir / "bonn");
  EXPECT_EQ(folder.info().layout, Layout::kBonnFolder);
  expect_same(folder.load(), b);

  make_zip(dir / "material.zip", entries, {"material/", "material/tv000_pv000/"});
  const auto zip = BtfSource::open(dir / "material.zip");
  EXPECT_EQ(zip.info().layout, Layout::kBonnZip);
  EXPECT_EQ(zip.info().ignored_files, 2u);
  EXPECT_GT(zip.info().file_bytes, 0u);
  EXPECT_TRUE(zip.info().lights == b.lights());
  EXPECT_TRUE(zip.info().views == b.views());
  EXPECT_EQ(zip.image_name(0, 0), "material/tv000_pv000/00000 tl000 pl000 tv000 pv000.png");
  expect_same(zip.load(), b);
  const Tile t{.x = 1, .y = 2, .width = 5, .height = 3};
  expect_same(zip.load(t), folder.load(t));
}

// The seamless-tile search reads a Bonn zip's images through the io layer's zip reader: the
// same seams as from the unpacked folder.
TEST(Dataset, TileSearchReadsABonnZipLikeItsFolder) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kLdr8, 8, 8);
  const auto entries = write_bonn_folder(b, dir / "bonn");
  make_zip(dir / "material.zip", entries);
  const auto from_folder = btfgmm::find_seamless_tile(BtfSource::open(dir / "bonn"), 5, 4);
  const auto from_zip = btfgmm::find_seamless_tile(BtfSource::open(dir / "material.zip"), 5, 4);
  EXPECT_EQ(from_zip.tile.x, from_folder.tile.x);
  EXPECT_EQ(from_zip.tile.y, from_folder.tile.y);
  EXPECT_EQ(from_zip.images, from_folder.images);
  EXPECT_GT(from_zip.images, 0u);
  EXPECT_DOUBLE_EQ(from_zip.seam.total, from_folder.seam.total);
}

TEST(Dataset, BonnJpegFolderAndZip) {
  TempDir dir;
  // Smooth content, so JPEG at quality 100 stays close to it.
  Btf b(DirectionSet::rings({{0, 1}, {45, 2}}), DirectionSet::rings({{0, 1}, {30, 2}}), 16, 8,
        SampleFormat::kLdr8);
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (std::size_t v = 0; v < b.views().size(); ++v)
      for (int y = 0; y < b.height(); ++y)
        for (int x = 0; x < b.width(); ++x)
          for (int c = 0; c < 3; ++c)
            b.at(l, v, x, y, c) = float(40 + 30 * int(l) + 20 * int(v) + 2 * x + y + 10 * c);
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> entries;
  for (std::size_t l = 0; l < b.lights().size(); ++l)
    for (std::size_t v = 0; v < b.views().size(); ++v) {
      const auto jpg = encode_jpeg(16, 8, to_bytes(b.image(l, v), b.image_floats()));
      const std::string rel = view_folder(b.views()[v]) + "/" + bonn_name(b, l, v, ".jpg");
      put_file(dir / ("bonn/" + rel), jpg);
      entries.emplace_back("material/" + rel, jpg);
    }
  make_zip(dir / "material.zip", entries);
  const auto folder = BtfSource::open(dir / "bonn");
  EXPECT_EQ(folder.info().layout, Layout::kBonnFolder);
  EXPECT_EQ(folder.info().image_format, ImageFormat::kJpeg);
  const auto zip = BtfSource::open(dir / "material.zip");
  const Btf a = folder.load(), z = zip.load();
  expect_same(a, z);
  for (std::size_t i = 0; i < a.data().size(); ++i) EXPECT_NEAR(a.data()[i], b.data()[i], 4.0);
}

TEST(Dataset, TileIsTheSubRectangleOfTheFullLoad) {
  for (const SampleFormat f : {SampleFormat::kLdr8, SampleFormat::kHdr}) {
    TempDir dir;
    btfgmm::write_utia(make_btf(f, 12, 10), dir.path());
    const auto src = BtfSource::open(dir.path());
    const Btf full = src.load();
    const Tile t{.x = 3, .y = 4, .width = 6, .height = 5};
    const Btf tile = src.load(t);
    ASSERT_EQ(tile.width(), 6);
    ASSERT_EQ(tile.height(), 5);
    EXPECT_EQ(tile.origin().x, 3);
    EXPECT_EQ(tile.origin().y, 4);
    EXPECT_EQ(tile.origin().width, 6);
    EXPECT_EQ(tile.origin().height, 5);
    for (std::size_t l = 0; l < full.lights().size(); ++l)
      for (std::size_t v = 0; v < full.views().size(); ++v)
        for (int y = 0; y < t.height; ++y)
          for (int x = 0; x < t.width; ++x)
            for (int c = 0; c < 3; ++c)
              ASSERT_EQ(tile.at(l, v, x, y, c), full.at(l, v, x + t.x, y + t.y, c));
  }
}

// ---- malformed data sets --------------------------------------------------------------------

TEST(Dataset, MissingFolder) {
  TempDir dir;
  EXPECT_ERROR(BtfSource::open(dir / "nope"), Error::Kind::kIo, (dir / "nope").string(),
               "does not exist");
  EXPECT_ERROR(BtfSource::open(dir / "nope.zip"), Error::Kind::kIo, "nope.zip");
}

TEST(Dataset, EmptyFolder) {
  TempDir dir;
  fs::create_directories(dir / "empty/sub");
  EXPECT_ERROR(BtfSource::open(dir / "empty"), Error::Kind::kFormat, (dir / "empty").string(),
               "no BTF images");
  put_file(dir / "empty/sub/notes.txt", {'a'});
  EXPECT_ERROR(BtfSource::open(dir / "empty"), Error::Kind::kFormat, (dir / "empty").string(),
               "1 non-image file ignored");
}

TEST(Dataset, OneImageMissing) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  fs::remove(dir / "tv030_pv000/tl045_pl090_tv030_pv000.png");
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat, dir.path().string(),
               "tv030_pv000/tl045_pl090_tv030_pv000.png", "1 of the 15 images");
}

TEST(Dataset, ManyImagesMissingListsFive) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  fs::remove_all(dir / "tv030_pv180");
  fs::remove(dir / "tv000_pv000/tl045_pl000_tv000_pv000.png");
  fs::remove(dir / "tv000_pv000/tl045_pl090_tv000_pv000.png");
  const Error e = error_of([&] { BtfSource::open(dir.path()); });
  const std::string msg = e.what();
  EXPECT_NE(msg.find("2 of the 10 images"), std::string::npos) << msg;  // pv180 view is gone
  EXPECT_NE(msg.find("tl045_pl090_tv000_pv000.png"), std::string::npos) << msg;
}

TEST(Dataset, UnparseableImageName) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  fs::copy_file(dir / "tv000_pv000/tl000_pl000_tv000_pv000.png", dir / "tv000_pv000/notes.png");
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat,
               (dir / "tv000_pv000/notes.png").string(), "is not a BTF image name");
}

TEST(Dataset, DuplicatePair) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  fs::create_directories(dir / "extra");
  fs::copy_file(dir / "tv030_pv000/tl000_pl000_tv030_pv000.png",
                dir / "extra/tl000_pl000_tv030_pv000.png");
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat,
               (dir / "extra/tl000_pl000_tv030_pv000.png").string(),
               (dir / "tv030_pv000/tl000_pl000_tv030_pv000.png").string());
  fs::remove(dir / "extra/tl000_pl000_tv030_pv000.png");
  // The same pair as .png and .jpg.
  fs::copy_file(dir / "tv030_pv000/tl000_pl000_tv030_pv000.png",
                dir / "tv030_pv000/tl000_pl000_tv030_pv000.jpg");
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat,
               (dir / "tv030_pv000/tl000_pl000_tv030_pv000.png").string(),
               (dir / "tv030_pv000/tl000_pl000_tv030_pv000.jpg").string());
}

TEST(Dataset, MixedImageFormats) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kLdr8, 8, 8);
  btfgmm::write_utia(b, dir.path());
  fs::remove(dir / "tv030_pv180/tl045_pl180_tv030_pv180.png");
  btfgmm::write_exr(dir / "tv030_pv180/tl045_pl180_tv030_pv180.exr", 8, 8,
                    std::span<const float>(b.image(3, 2), b.image_floats()));
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat,
               "tv030_pv180/tl045_pl180_tv030_pv180.exr", "mixes image formats");
}

TEST(Dataset, TwoImageSizes) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  const std::vector<float> small(6 * 5 * 3, 9.0f);
  btfgmm::write_png(dir / "tv030_pv000/tl045_pl000_tv030_pv000.png", 6, 5, small);
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat,
               (dir / "tv000_pv000/tl000_pl000_tv000_pv000.png").string() + " is 8x8",
               (dir / "tv030_pv000/tl045_pl000_tv030_pv000.png").string() + " is 6x5", "one size");
}

TEST(Dataset, TruncatedPng) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  const fs::path p = dir / "tv030_pv180/tl045_pl000_tv030_pv180.png";
  auto bytes = file_bytes(p);
  bytes.resize(bytes.size() - 20);
  put_file(p, bytes);
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat, p.string(), "truncated");
  // Cut inside the pixel data too.
  bytes.resize(bytes.size() / 2);
  put_file(p, bytes);
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat, p.string());
}

TEST(Dataset, TruncatedAfterOpenFailsOnLoad) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  const auto src = BtfSource::open(dir.path());
  const fs::path p = dir / "tv000_pv000/tl045_pl270_tv000_pv000.png";
  auto bytes = file_bytes(p);
  bytes.resize(bytes.size() - 20);
  put_file(p, bytes);
  EXPECT_ERROR(src.load(), Error::Kind::kFormat, p.string());
  fs::remove(p);
  EXPECT_ERROR(src.load(), Error::Kind::kIo, p.string());
}

TEST(Dataset, JpegWithPngName) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  const fs::path p = dir / "tv000_pv000/tl045_pl180_tv000_pv000.png";
  put_file(p, encode_jpeg(8, 8, std::vector<std::uint8_t>(8 * 8 * 3, 50)));
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat, p.string(), "holds JPEG data",
               "rename it to .jpg");
}

TEST(Dataset, ZipWithJunkBytes) {
  TempDir dir;
  std::vector<std::uint8_t> junk(300);
  for (std::size_t i = 0; i < junk.size(); ++i) junk[i] = std::uint8_t(mix(i));
  put_file(dir / "junk.zip", junk);
  EXPECT_ERROR(BtfSource::open(dir / "junk.zip"), Error::Kind::kFormat, (dir / "junk.zip").string(),
               "not a readable zip archive");
  // A valid zip holding a broken image names the entry.
  make_zip(dir / "bad.zip", {{"m/tv000_pv000/00000 tl000 pl000 tv000 pv000.png", junk}});
  EXPECT_ERROR(BtfSource::open(dir / "bad.zip"), Error::Kind::kFormat, "bad.zip",
               "m/tv000_pv000/00000 tl000 pl000 tv000 pv000.png");
  // A zip with no images.
  make_zip(dir / "none.zip", {{"readme.txt", junk}});
  EXPECT_ERROR(BtfSource::open(dir / "none.zip"), Error::Kind::kFormat, "none.zip",
               "no BTF images");
}

TEST(Dataset, ExrWithNaN) {
  TempDir dir;
  Btf b = make_btf(SampleFormat::kHdr, 8, 6);
  b.at(1, 2, 3, 4, 1) = std::numeric_limits<float>::quiet_NaN();
  btfgmm::write_utia(b, dir.path());
  const auto src = BtfSource::open(dir.path());  // headers are fine
  EXPECT_ERROR(src.load(), Error::Kind::kFormat,
               (dir / "tv030_pv180/tl045_pl000_tv030_pv180.exr").string(), "x=3 y=4", "channel G",
               "replace non-finite values");
  // A tile without the bad pixel loads.
  EXPECT_NO_THROW(src.load(Tile{.x = 4, .y = 0, .width = 4, .height = 6}));
}

TEST(Dataset, TileOutsideTheImage) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 12, 10), dir.path());
  const auto src = BtfSource::open(dir.path());
  for (const Tile t : {Tile{.x = 10, .y = 0, .width = 5, .height = 5},
                       Tile{.x = -1, .y = 0, .width = 5, .height = 5},
                       Tile{.x = 0, .y = 6, .width = 5, .height = 5},
                       Tile{.x = 0, .y = 0, .width = 13, .height = 1}})
    EXPECT_ERROR(src.load(t), Error::Kind::kArgument, dir.path().string(), "12x10");
}

TEST(Dataset, ViewFolderDisagreesWithName) {
  TempDir dir;
  btfgmm::write_utia(make_btf(SampleFormat::kLdr8, 8, 8), dir.path());
  fs::rename(dir / "tv000_pv000/tl000_pl000_tv000_pv000.png",
             dir / "tv030_pv000/tl000_pl000_tv000_pv000.png");
  EXPECT_ERROR(BtfSource::open(dir.path()), Error::Kind::kFormat,
               (dir / "tv030_pv000/tl000_pl000_tv000_pv000.png").string(), "tv000_pv000");
}

TEST(Dataset, NotAFolderOrZip) {
  TempDir dir;
  put_file(dir / "file.txt", {'a'});
  EXPECT_ERROR(BtfSource::open(dir / "file.txt"), Error::Kind::kArgument,
               (dir / "file.txt").string());
}

TEST(Dataset, WriteUtiaRejectsJpegAndUnwritableFolder) {
  TempDir dir;
  const Btf b = make_btf(SampleFormat::kLdr8, 4, 4);
  EXPECT_ERROR(btfgmm::write_utia(b, dir / "out", ImageFormat::kJpeg), Error::Kind::kArgument,
               "out");
  put_file(dir / "blocker", {'a'});
  EXPECT_ERROR(btfgmm::write_utia(b, dir / "blocker"), Error::Kind::kIo, "blocker");
}
