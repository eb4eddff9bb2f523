// What the library tells a user who went wrong or waits: the nearest name to a mistyped one, what
// a file holds when it is not a model, the progress of a long generation, and output images
// written in the format their names say.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/file_kind.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/io/utia.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/synth/generate.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using test::error_of;

std::vector<std::uint8_t> bytes_of(std::string_view s, std::size_t size = 0) {
  std::vector<std::uint8_t> b(s.begin(), s.end());
  if (b.size() < size) b.resize(size, 0);
  return b;
}

fs::path fresh_dir() {
  const fs::path d = fs::temp_directory_path() /
                     ("btfgmm_messages_" +
                      std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
                      "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(Messages, NearestNameIsWithinTwoEditsAndHalfTheName) {
  const std::vector<std::string_view> options{"--iterations", "--epsilon", "--tile", "--seed"};
  EXPECT_EQ(nearest_name("--itterations", options), "--iterations");
  EXPECT_EQ(nearest_name("--iteration", options), "--iterations");
  EXPECT_EQ(nearest_name("--tille", options), "--tile");
  EXPECT_EQ(nearest_name("--colour", options), "");
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  const std::vector<std::string_view> methods{"gm", "pca-btf", "pca-rf"};
  EXPECT_EQ(nearest_name("gn", methods), "gm");
  EXPECT_EQ(nearest_name("xy", methods), "");  // two edits of a two-letter name: no guess
  EXPECT_EQ(nearest_name("pca-rt", methods), "pca-rf");
  EXPECT_EQ(did_you_mean("lether", std::vector<std::string_view>{"knit", "leather"}),
            " (did you mean 'leather'?)");
  EXPECT_EQ(did_you_mean("velvet", std::vector<std::string_view>{"knit", "leather"}), "");
}

TEST(Messages, NearestNamesMatchByCaseAndPrefixBeforeEdits) {
  const std::vector<std::string_view> methods{"gm", "pca-btf", "pca-rf", "lpca", "ptm-rf"};
  EXPECT_EQ(did_you_mean("pca", methods), " (did you mean 'pca-btf' or 'pca-rf'?)");
  EXPECT_EQ(did_you_mean("PCA-BTF", methods), " (did you mean 'pca-btf'?)");
  EXPECT_EQ(did_you_mean("LPCA", methods), " (did you mean 'lpca'?)");
  EXPECT_EQ(did_you_mean("Pca-Rt", methods), " (did you mean 'pca-rf'?)");  // case, then edits
  EXPECT_EQ(nearest_names("p", methods), std::vector<std::string>{});       // one letter: no guess
  const std::vector<std::string_view> many{"--a1", "--a2", "--a3", "--a4"};
  // A prefix of more than three names lists none of them; the nearest by edits remains.
  EXPECT_EQ(nearest_names("--a", many), std::vector<std::string>{"--a1"});
  EXPECT_EQ(did_you_mean("pt", methods), " (did you mean 'ptm-rf'?)");
  const std::string msg = error_of([] { find_method("pca"); });
  EXPECT_NE(msg.find("'pca' (did you mean 'pca-btf' or 'pca-rf'?)"), std::string::npos) << msg;
}

TEST(Messages, MaterialsComeFromOneTableAndMistypingsGetTheNearest) {
  const std::vector<std::string> names = material_names();
  ASSERT_EQ(names.size(), materials().size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(names[i], materials()[i].name);
    EXPECT_FALSE(materials()[i].description.empty()) << names[i];
  }
  EXPECT_NE(std::find(names.begin(), names.end(), "leather"), names.end());
  GenerateConfig c;
  c.material = "lether";
  const std::string msg = error_of([&] { check_generate_config(c); });
  EXPECT_NE(msg.find("unknown material 'lether' (did you mean 'leather'?)"), std::string::npos)
      << msg;
  EXPECT_NE(msg.find("corduroy, knit, bumps, leather"), std::string::npos) << msg;
}

TEST(Messages, IdentifiesCommonFilesByTheirFirstBytes) {
  std::vector<std::uint8_t> tar = bytes_of("c/", 512);
  std::copy_n("ustar", 5, tar.begin() + 257);
  const struct {
    std::vector<std::uint8_t> head;
    FileKind::Class kind;
    std::string_view what;
  } cases[] = {
      {bytes_of("\x1f\x8b\x08\x00", 32), FileKind::Class::kArchive, "a gzip archive"},
      {tar, FileKind::Class::kArchive, "a tar archive"},
      {bytes_of("BZh91AY", 32), FileKind::Class::kArchive, "a bzip2 archive"},
      {bytes_of("\xfd\x37\x7a\x58\x5a\x00", 32), FileKind::Class::kArchive, "an xz archive"},
      {bytes_of("PK\x03\x04", 32), FileKind::Class::kZip, "a zip archive"},
      {bytes_of("\x89PNG\r\n\x1a\n", 32), FileKind::Class::kImage, "a PNG image"},
      {bytes_of("\xff\xd8\xff\xe0", 32), FileKind::Class::kImage, "a JPEG image"},
      {bytes_of("\x76\x2f\x31\x01", 32), FileKind::Class::kImage, "an OpenEXR image"},
      {bytes_of("II*\0", 32), FileKind::Class::kImage, "a TIFF image"},
      {bytes_of("BM", 32), FileKind::Class::kImage, "a BMP image"},
      {bytes_of("%PDF-1.7", 32), FileKind::Class::kOther, "a PDF document"},
      {bytes_of("v 0 0 0\nvt 0 0\n"), FileKind::Class::kOther, "a text file"},
  };
  for (const auto& c : cases) {
    const auto k = identify_file(c.head);
    ASSERT_TRUE(k.has_value()) << c.what;
    EXPECT_EQ(k->kind, c.kind) << c.what;
    EXPECT_EQ(k->what, c.what);
  }
  // A btfgmm model, and bytes of no known kind, are none of these.
  EXPECT_FALSE(
      identify_file(model_file_bytes("gm", 0, Provenance{}, bytes_of("", 64))).has_value());
  EXPECT_FALSE(identify_file(bytes_of("\x01\x02\x03\x00\xfe", 64)).has_value());
  EXPECT_FALSE(identify_file({}).has_value());
  EXPECT_EQ(unread_image_format_from_name("a.TIFF"), "TIFF");
  EXPECT_EQ(unread_image_format_from_name("tl000_pl000_tv000_pv000.bmp"), "BMP");
  EXPECT_FALSE(unread_image_format_from_name("a.png").has_value());
}

TEST(Messages, AModelReaderSaysWhatTheFileIsAndWhatToDo) {
  auto message = [](std::string_view bytes, const std::string& name) {
    return error_of([&] { read_representation(bytes_of(bytes, 600), name); });
  };
  std::string m = message("\x1f\x8b\x08\x00", "c.tar.gz");
  EXPECT_NE(m.find("'c.tar.gz' is a gzip archive, not a btfgmm model"), std::string::npos) << m;
  EXPECT_NE(m.find("extract it and fit the BTF images it holds (a folder of images), then give "
                   "the model file here"),
            std::string::npos)
      << m;
  m = message("PK\x03\x04", "UBO_CORDUROY256.zip");
  EXPECT_NE(m.find("is a zip archive, not a btfgmm model"), std::string::npos) << m;
  EXPECT_NE(m.find("fit a model to 'UBO_CORDUROY256.zip', then give the model file here"),
            std::string::npos)
      << m;
  m = message("\xff\xd8\xff\xe0", "photo.btfgmm");
  EXPECT_NE(m.find("'photo.btfgmm' is a JPEG image, not a btfgmm model"), std::string::npos) << m;
  m = message("\x01\x02\x00", "junk.btfgmm");
  EXPECT_NE(m.find("does not start with the btfgmm magic bytes"), std::string::npos) << m;
  // A checkpoint of an unfinished fit, given where a model is expected: named, and its resume.
  m = message(
      "\x89"
      "BTFCKP\n\x02\x00\x00\x00",
      "big.ckpt");
  EXPECT_NE(m.find("'big.ckpt' is a btfgmm checkpoint of a fit, not a btfgmm model"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("continue it by giving 'big.ckpt' to the option --resume"), std::string::npos)
      << m;
}

TEST(Messages, AFileIsNamedFromItsFirstBytesBeforeItIsReadWhole) {
  const fs::path dir = fresh_dir();
  {
    std::ofstream out(dir / "c.tar.gz", std::ios::binary);
    out << std::string("\x1f\x8b\x08\x00", 4) << std::string(5000, 'x');
  }
  EXPECT_EQ(read_file_start(dir / "c.tar.gz", 512).size(), 512u);
  EXPECT_EQ(read_file_start(dir / "c.tar.gz", 9000).size(), 5004u);
  EXPECT_TRUE(read_file_start(dir, 512).empty());
  EXPECT_TRUE(read_file_start(dir / "missing", 512).empty());
  const std::string m = error_of([&] { load_representation(dir / "c.tar.gz"); });
  EXPECT_NE(m.find("c.tar.gz' is a gzip archive, not a btfgmm model"), std::string::npos) << m;
  fs::remove_all(dir);
}

TEST(Messages, AFolderGivenAsAModelIsNamedAndTheFitShown) {
  const fs::path dir = fresh_dir();
  Btf b(DirectionSet::rings({{0, 1}}), DirectionSet::rings({{0, 1}}), 4, 4, SampleFormat::kLdr8);
  write_utia(b, dir / "btf");
  std::string m = error_of([&] { load_representation(dir / "btf"); });
  EXPECT_NE(m.find("is a folder of images, not a model; fit a model to it first, then give the "
                   "model file here"),
            std::string::npos)
      << m;
  fs::create_directories(dir / "empty");
  m = error_of([&] { load_representation(dir / "empty"); });
  EXPECT_NE(m.find("is a folder, not a model file"), std::string::npos) << m;
  fs::remove_all(dir);
}

TEST(Messages, GenerationAndWritingReportTheirProgress) {
  GenerateConfig c;
  c.size = 8;
  c.supersample = 1;
  c.lights = DirectionSet::rings({{0, 1}, {45, 4}});
  c.views = DirectionSet::rings({{0, 1}, {45, 4}});
  std::vector<double> rendered;
  c.progress = [&](double f, std::string_view stage) {
    EXPECT_EQ(stage, "images");
    rendered.push_back(f);
  };
  const Btf b = generate(c);
  ASSERT_EQ(rendered.size(), 5u);  // one band of rows per view at this size
  for (std::size_t i = 0; i < rendered.size(); ++i)
    EXPECT_DOUBLE_EQ(rendered[i], double(i + 1) / 5.0);
  const fs::path dir = fresh_dir();
  std::vector<double> written;
  write_utia(b, dir / "btf", std::nullopt, [&](double f) { written.push_back(f); });
  ASSERT_EQ(written.size(), 25u);
  EXPECT_DOUBLE_EQ(written.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(written.begin(), written.end()));
  fs::remove_all(dir);
}

TEST(Messages, ImagesAreWrittenInTheFormatTheirNamesSay) {
  const fs::path dir = fresh_dir();
  std::vector<float> levels(4 * 2 * 3);
  for (std::size_t i = 0; i < levels.size(); ++i) levels[i] = float(i * 10);
  write_picture(dir / "a.jpg", 4, 2, levels);
  write_picture(dir / "b.JPEG", 4, 2, levels);
  write_picture(dir / "c.png", 4, 2, levels);
  write_picture(dir / "d.exr", 4, 2, levels);
  auto head = [&](const char* name) {
    std::ifstream in(dir / name, std::ios::binary);
    std::vector<std::uint8_t> b(16);
    in.read(reinterpret_cast<char*>(b.data()), 16);
    return identify_file(b)->what;
  };
  EXPECT_EQ(head("a.jpg"), "a JPEG image");
  EXPECT_EQ(head("b.JPEG"), "a JPEG image");
  EXPECT_EQ(head("c.png"), "a PNG image");
  EXPECT_EQ(head("d.exr"), "an OpenEXR image");
  // The EXR holds linear values: the levels decoded from sRGB.
  const Image exr = read_image(dir / "d.exr");
  EXPECT_FLOAT_EQ(exr.rgb[0], 0.0f);
  EXPECT_NEAR(exr.rgb[23], std::pow((230.0 / 255.0 + 0.055) / 1.055, 2.4), 1e-6);
  const Image jpeg = read_image(dir / "a.jpg");
  for (std::size_t i = 0; i < levels.size(); ++i) EXPECT_NEAR(jpeg.rgb[i], levels[i], 12.0) << i;
  const std::string m = error_of([&] { write_picture(dir / "e.tif", 4, 2, levels); });
  EXPECT_NE(m.find("e.tif"), std::string::npos) << m;
  EXPECT_NE(m.find(".png, .jpg (or .jpeg) or .exr"), std::string::npos) << m;
  EXPECT_FALSE(fs::exists(dir / "e.tif"));
  fs::remove_all(dir);
}

// The library names options by their fields, marked; a front end spells each marked name its
// own way and leaves every other character, other backquoted text included, as it was.
TEST(Messages, OptionNamesAreSpelledByTheFrontEnd) {
  EXPECT_EQ(option_name("refine_steps"), "`refine_steps`");
  const std::string m = option_name("refine_steps") + " 0: give 1 to 9 (see `btfgmm sweep`, `" +
                        ", " + option_name("tile") + ")`";
  const auto flag = [](std::string_view f) { return "--<" + std::string(f) + ">"; };
  EXPECT_EQ(spell_options(m, flag),
            "--<refine_steps> 0: give 1 to 9 (see `btfgmm sweep`, `, "
            "--<tile>)`");
  EXPECT_EQ(spell_options("`` `A` `a", flag), "`` `A` `a");
  EXPECT_EQ(spell_options("", flag), "");
}

}  // namespace
}  // namespace btfgmm
