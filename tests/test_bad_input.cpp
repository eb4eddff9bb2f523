// The bad-input matrix of the btfgmm command: one test per hostile input. Each runs the real
// binary and expects a clean refusal: exit status 1 (an error) or 2 (bad usage), never a
// signal; a message naming the file or option at fault and the fix; no output file (and no
// temporary file) left behind.
//
// The tests run as root in CI, where chmod cannot make a folder read-only; a read-only folder
// is /proc (no file can be created there) and, where mounting is permitted, a read-only tmpfs.
// A full disk is a 64 KiB tmpfs filled up; those tests skip when mount(2) is refused.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <stb/stb_image_write.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <string>
#include <vector>

#include <zip.h>
#include <zlib.h>

#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"

#include "test_util.hpp"

namespace {

namespace fs = std::filesystem;

struct CliRun {
  int status = 0;   // the exit status; 128 + N when killed by signal N (as the shell reports)
  std::string out;  // stdout and stderr together
};

CliRun run(const std::string& args, const std::string& prefix = "") {
  const fs::path log =
      fs::temp_directory_path() / ("btfgmm_bad_input_" + std::to_string(::getpid()) + ".log");
  const std::string cmd =
      prefix + std::string(BTFGMM_CLI_PATH) + " " + args + " > " + log.string() + " 2>&1";
  CliRun r;
  const int raw = std::system(cmd.c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + (WIFSIGNALED(raw) ? WTERMSIG(raw) : 0);
  std::ifstream in(log);
  r.out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  fs::remove(log);
  return r;
}

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
}

// Temporary or probe files left by a failed write, anywhere under `dir`.
std::vector<std::string> leftovers(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.find(".tmp-") != std::string::npos || name.find(".btfgmm-probe") != std::string::npos)
      out.push_back(it->path().string());
  }
  return out;
}

// A refusal: exit 1 or 2 (not a crash, not a signal), every needle in the message.
void expect_refused(const CliRun& r, std::initializer_list<std::string> needles) {
  EXPECT_TRUE(r.status == 1 || r.status == 2) << "exit status " << r.status << ": " << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;
  for (const std::string& n : needles)
    EXPECT_NE(r.out.find(n), std::string::npos) << "message lacks '" << n << "': " << r.out;
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("btfgmm_bad_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    for (const auto& m : mounts_) ::umount2(m.c_str(), MNT_DETACH);
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string p(const std::string& name) const { return (dir_ / name).string(); }

  // The small BTF of these tests: 5 lights x 6 views of 8 x 8 pixels, written by the CLI.
  void generate(const std::string& name = "btf", const std::string& extra = "--size 8") {
    const CliRun r =
        run("generate --lights rings:0/1,30/4 --views rings:0/1,45/5 " + extra + " -o " + p(name));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  // A model of that BTF.
  void fit(const std::string& model = "m.btfgmm") {
    if (!fs::exists(p("btf"))) generate();
    const CliRun r = run("fit " + p("btf") + " -M 3 --iterations 1 -q -o " + p(model));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  // `fit` of the BTF into m.btfgmm, expected to be refused, leaving no model behind.
  void expect_fit_refused(const std::string& input, const std::string& options,
                          std::initializer_list<std::string> needles) {
    const CliRun r = run("fit " + input + " " + options + " -o " + p("m.btfgmm"));
    expect_refused(r, needles);
    EXPECT_FALSE(fs::exists(p("m.btfgmm")));
    EXPECT_TRUE(leftovers(dir_).empty()) << leftovers(dir_).front();
  }
  // Mounts a tmpfs of 64 KiB on `name` (read-only if asked); false when not permitted.
  bool mount_tmpfs(const std::string& name, bool read_only) {
    fs::create_directories(p(name));
    if (::mount("tmpfs", p(name).c_str(), "tmpfs", read_only ? MS_RDONLY : 0, "size=64k") != 0)
      return false;
    mounts_.push_back(p(name));
    return true;
  }

  fs::path dir_;
  std::vector<std::string> mounts_;
};

const char* kImage = "tv045_pv072/tl030_pl090_tv045_pv072.png";

// ---- data sets ---------------------------------------------------------------------------

TEST_F(BadInput, MissingFolder) {
  expect_fit_refused(p("nowhere"), "", {p("nowhere"), "does not exist", "give a folder"});
}

TEST_F(BadInput, EmptyFolder) {
  fs::create_directories(p("empty"));
  expect_fit_refused(p("empty"), "", {p("empty"), "no BTF images found", "expected images named"});
}

TEST_F(BadInput, OneImageMissing) {
  generate();
  fs::remove(p("btf/") + kImage);
  expect_fit_refused(p("btf"), "",
                     {"1 of the 30 images", kImage, "every (light, view) pair needs exactly one"});
}

TEST_F(BadInput, ExtraUnparseableName) {
  generate();
  fs::copy_file(p("btf/") + kImage, p("btf/tv045_pv072/notes.png"));
  expect_fit_refused(p("btf"), "",
                     {p("btf/tv045_pv072/notes.png"), "is not a BTF image name",
                      "rename the file or move it out"});
}

TEST_F(BadInput, TwoSizesOfImage) {
  generate();
  generate("big", "--size 12");
  fs::copy_file(p("big/") + kImage, p("btf/") + kImage, fs::copy_options::overwrite_existing);
  expect_fit_refused(p("btf"), "", {p("btf/") + kImage + " is 12x12", "is 8x8", "one size"});
}

TEST_F(BadInput, TruncatedPng) {
  generate();
  const std::string bytes = read_bytes(p("btf/") + kImage);
  write_bytes(p("btf/") + kImage, bytes.substr(0, bytes.size() / 2));
  expect_fit_refused(p("btf"), "", {p("btf/") + kImage, "truncated", "re-copy or re-export"});
}

TEST_F(BadInput, JpegWithPngName) {
  generate();
  std::string jpeg;
  const std::vector<std::uint8_t> grey(8 * 8 * 3, 99);
  stbi_write_jpg_to_func(
      [](void* ctx, void* data, int size) {
        static_cast<std::string*>(ctx)->append(static_cast<const char*>(data), std::size_t(size));
      },
      &jpeg, 8, 8, 3, grey.data(), 90);
  write_bytes(p("btf/") + kImage, jpeg);
  expect_fit_refused(p("btf"), "", {p("btf/") + kImage, "holds JPEG data", "rename it to .jpg"});
}

TEST_F(BadInput, ZipWithJunk) {
  std::string junk;
  for (int i = 0; i < 1000; ++i) junk += char((i * 7919) % 251);
  write_bytes(p("junk.zip"), junk);
  expect_fit_refused(p("junk.zip"), "",
                     {p("junk.zip"), "not a readable zip archive", "give a Bonn material .zip"});
  // A zip's magic and end record followed by junk: still refused by name.
  write_bytes(p("junk.zip"), "PK\x05\x06" + junk);
  expect_fit_refused(p("junk.zip"), "", {p("junk.zip"), "zip"});
}

TEST_F(BadInput, ExrWithNanOrInf) {
  generate("btf", "--size 8 --hdr");
  const std::string image = p("btf/tv045_pv072/tl030_pl090_tv045_pv072.exr");
  for (const float bad :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    std::vector<float> rgb(8 * 8 * 3, 0.25f);
    rgb[(3 * 8 + 5) * 3 + 2] = bad;
    btfgmm::write_exr(image, 8, 8, rgb);
    expect_fit_refused(p("btf"), "",
                       {image, "non-finite", "x=5 y=3", "channel B", "replace non-finite values"});
  }
}

TEST_F(BadInput, TileOutsideTheImage) {
  generate();
  expect_fit_refused(p("btf"), "--tile 4,4,8,8", {"tile x=4 y=4 8x8", "not inside", p("btf")});
  expect_fit_refused(p("btf"), "--tile 0,0,0,4", {"--tile '0,0,0,4'", "width, height >= 1"});
  expect_fit_refused(p("btf"), "--tile -1,0,4,4", {"--tile", "x, y must be >= 0"});
}

// ---- options -----------------------------------------------------------------------------

TEST_F(BadInput, ComponentsZeroNegativeHuge) {
  generate();
  for (const char* m : {"0", "-5", "1000000000"})
    expect_fit_refused(p("btf"), std::string("--components ") + m, {"--components", m});
  expect_fit_refused(p("btf"), "-M 0", {"--components", "0"});
  // In range for the option, more than the 8 x 8 x 30 = 1920 samples of the data: EM's
  // refusal, and, for the default objective, the refinement's, before it.
  expect_fit_refused(p("btf"), "--components 5000 --objective likelihood",
                     {"components = 5000", "more than the 1920 samples", "give fewer components"});
  expect_fit_refused(p("btf"), "--components 5000",
                     {"--components 5000", "1920 samples support at most 28 components"});
}

TEST_F(BadInput, ComponentsBeyondMemory) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer cannot run under an address-space limit";
#else
  // A 64 x 64 tile of 30 images (122,880 samples) with M = 100,000: EM's tables alone need
  // about 4.6 GiB. Under a 2 GiB address-space limit that is refused before any allocation.
  btfgmm::Btf b(btfgmm::DirectionSet::rings({{0, 1}, {30, 4}}),
                btfgmm::DirectionSet::rings({{0, 1}, {45, 5}}), 64, 64,
                btfgmm::SampleFormat::kLdr8);
  for (std::size_t i = 0; i < b.data().size(); ++i) b.data()[i] = float(i % 251);
  btfgmm::write_utia(b, p("btf"));
  const CliRun r =
      run("fit " + p("btf") + " --components 100000 --objective likelihood -o " + p("m.btfgmm"),
          "ulimit -v 2097152; ");
  expect_refused(r, {"M = 100000", "64x64 tile", "more than the 2.0 GiB this machine has",
                     "give fewer components (--components) or a smaller tile (--tile)"});
  EXPECT_FALSE(fs::exists(p("m.btfgmm")));
#endif
}

TEST_F(BadInput, IterationsZero) {
  generate();
  expect_fit_refused(p("btf"), "--iterations 0", {"--iterations", "0", "range"});
}

TEST_F(BadInput, DecodeSizeBeyondMemory) {
  fit();
  // Past what decode writes without asking: refused before any work, --yes named.
  CliRun r = run("decode " + p("m.btfgmm") + " --size 65536x65536 -o " + p("dec"));
  expect_refused(r, {"decode would write 30 images of 65536x65536 pixels, 360.0 GiB of 8-bit RGB",
                     "more than the 1.0 GiB it writes without asking; give --yes"});
  EXPECT_FALSE(fs::exists(p("dec")));
  // With --yes, beyond the machine's memory: refused as before.
  r = run("decode " + p("m.btfgmm") + " --size 65536x65536 --yes -o " + p("dec"));
  expect_refused(r, {"decoding 6 images of 65536x65536 pixels", "more than the",
                     "decode a smaller size (--size)"});
  EXPECT_FALSE(fs::exists(p("dec")));
  expect_refused(run("decode " + p("m.btfgmm") + " --size 0x4 -o " + p("dec")),
                 {"--size '0x4'", "give N or WxH pixels"});
}

TEST_F(BadInput, RenderSizeBeyondMemory) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer cannot run under an address-space limit";
#else
  fit();
  // 16384 x 16384 is in range for --size; under a 2 GiB limit it is refused before rendering.
  const CliRun r = run("render " + p("m.btfgmm") + " --size 16384x16384 -o " + p("r.png"),
                       "ulimit -v 2097152; ");
  expect_refused(r, {"rendering 16384x16384 pixels needs about", "give a smaller --size"});
  EXPECT_FALSE(fs::exists(p("r.png")));
#endif
}

// ---- model files -------------------------------------------------------------------------

// `eval` of a damaged model: refused with a message naming it.
void expect_model_refused(const std::string& model, std::initializer_list<std::string> needles) {
  expect_refused(run("eval " + model + " --x 1 --y 2 --light 30,0 --view 0,0"), needles);
  expect_refused(run("info " + model), needles);
}

TEST_F(BadInput, ModelTruncated) {
  fit();
  const std::string bytes = read_bytes(p("m.btfgmm"));
  write_bytes(p("cut.btfgmm"), bytes.substr(0, bytes.size() - 7));
  expect_model_refused(p("cut.btfgmm"), {p("cut.btfgmm"), "truncated", "fit or copy it again"});
  write_bytes(p("cut.btfgmm"), bytes.substr(0, 20));
  expect_model_refused(p("cut.btfgmm"), {p("cut.btfgmm"), "truncated"});
}

TEST_F(BadInput, ModelBitFlipped) {
  fit();
  std::string bytes = read_bytes(p("m.btfgmm"));
  bytes[bytes.size() / 2] = char(bytes[bytes.size() / 2] ^ 0x10);
  write_bytes(p("flip.btfgmm"), bytes);
  expect_model_refused(p("flip.btfgmm"), {p("flip.btfgmm"), "corrupted", "copy or fit it again"});
}

TEST_F(BadInput, ModelOfANewerVersion) {
  fit();
  std::string bytes = read_bytes(p("m.btfgmm"));
  const std::uint32_t newer = btfgmm::kModelFormatVersion + 1;
  bytes[8] = char(newer);  // the format version, u32 little-endian at byte 8
  write_bytes(p("new.btfgmm"), bytes);
  expect_model_refused(p("new.btfgmm"), {p("new.btfgmm"), "format version " + std::to_string(newer),
                                         "use a newer btfgmm"});
}

TEST_F(BadInput, ModelOfZeroBytes) {
  write_bytes(p("zero.btfgmm"), "");
  expect_model_refused(p("zero.btfgmm"), {p("zero.btfgmm"), "empty (0 bytes)", "fit the model"});
}

TEST_F(BadInput, ModelThatIsAPng) {
  generate();
  fs::copy_file(p("btf/") + kImage, p("png.btfgmm"));
  expect_model_refused(p("png.btfgmm"), {p("png.btfgmm"), "is a PNG image, not a btfgmm model",
                                         "fitted to a folder of BTF images: fit the folder"});
}

TEST_F(BadInput, EvalAnglesOutOfRangeOrNan) {
  fit();
  const std::string eval = "eval " + p("m.btfgmm") + " --x 1 --y 2 ";
  expect_refused(run(eval + "--light 95,0 --view 0,0"),
                 {"--light '95,0'", "theta 95", "give theta in [0, 90]"});
  expect_refused(run(eval + "--light 30,0 --view -1,0"),
                 {"--view '-1,0'", "give theta in [0, 90]"});
  expect_refused(run(eval + "--light nan,0 --view 0,0"),
                 {"--light 'nan,0'", "not a finite number", "write it like 30,45"});
  expect_refused(run(eval + "--light 30,0 --view 10,inf"), {"--view '10,inf'", "finite"});
  expect_refused(run("eval " + p("m.btfgmm") + " --x nan --y 2 --light 30,0 --view 0,0"),
                 {"x=nan", "give finite x and y"});
}

// ---- outputs -----------------------------------------------------------------------------

TEST_F(BadInput, OutputFolderDoesNotExist) {
  generate();
  const CliRun r = run("fit " + p("btf") + " -M 3 --iterations 1 -o " + p("missing/m.btfgmm"));
  expect_refused(r, {p("missing/m.btfgmm"), "does not exist", "create it first"});
  EXPECT_FALSE(fs::exists(p("missing")));
  // A file where the folder should be.
  write_bytes(p("afile"), "x");
  expect_refused(run("fit " + p("btf") + " -M 3 --iterations 1 -o " + p("afile/m.btfgmm")),
                 {p("afile"), "is a file, not a folder"});
  fit();
  expect_refused(run("decode " + p("m.btfgmm") + " -o " + p("afile/dec")),
                 {p("afile"), "is a file, not a folder"});
  EXPECT_TRUE(leftovers(dir_).empty()) << leftovers(dir_).front();
}

TEST_F(BadInput, OutputFolderReadOnly) {
  // As root, permissions do not stop a write; /proc refuses every new file.
  generate();
  CliRun r = run("fit " + p("btf") + " -M 3 --iterations 1 -o /proc/m.btfgmm");
  expect_refused(r, {"/proc/m.btfgmm", "no file can be created in the folder '/proc'",
                     "give an output path in a folder you can write to"});
  EXPECT_EQ(r.out.find("iteration"), std::string::npos) << "refused only after the fit: " << r.out;
  EXPECT_FALSE(fs::exists("/proc/m.btfgmm"));
  r = run("generate --size 8 -o /proc/btf");
  expect_refused(r, {"/proc/btf", "give an output path in a folder you can write to"});
  if (!mount_tmpfs("ro", true)) GTEST_SKIP() << "mount(2) refused: " << std::strerror(errno);
  r = run("fit " + p("btf") + " -M 3 --iterations 1 -o " + p("ro/m.btfgmm"));
  expect_refused(r, {p("ro/m.btfgmm"), "Read-only file system", "a folder you can write to"});
  EXPECT_TRUE(fs::is_empty(p("ro")));
}

TEST_F(BadInput, FullDisk) {
  fit("ok.btfgmm");
  if (!mount_tmpfs("full", false)) GTEST_SKIP() << "mount(2) refused: " << std::strerror(errno);
  // Fill the 64 KiB file system.
  {
    std::ofstream fill(p("full/filler"), std::ios::binary);
    const std::string block(4096, 'x');
    for (int i = 0; i < 64 && fill; ++i) fill << block << std::flush;
  }
  const CliRun r = run("fit " + p("btf") + " -M 3 --iterations 1 -q -o " + p("full/m.btfgmm"));
  expect_refused(
      r, {p("full/m.btfgmm"), "No space left on device", "nothing was written under that name",
          "free space on that disk or write elsewhere"});
  EXPECT_FALSE(fs::exists(p("full/m.btfgmm")));
  EXPECT_TRUE(leftovers(p("full")).empty()) << leftovers(p("full")).front();
  // Decoding into it: refused, no temporary image left.
  expect_refused(run("decode " + p("ok.btfgmm") + " -o " + p("full/dec")),
                 {p("full/dec"), "No space left on device", "free space on that disk"});
  EXPECT_TRUE(leftovers(p("full")).empty()) << leftovers(p("full")).front();
}

// ---- the wrong thing in the right place: the message names what it is -------------------

// Every image of the BTF renamed from the extension `from` to `to`.
void rename_images(const fs::path& btf, const std::string& from, const std::string& to) {
  std::vector<fs::path> images;
  for (const auto& e : fs::recursive_directory_iterator(btf))
    if (e.path().extension() == from) images.push_back(e.path());
  for (const fs::path& image : images) fs::rename(image, fs::path(image).replace_extension(to));
}

TEST_F(BadInput, FolderOfTiffOrBmpImages) {
  generate();
  rename_images(p("btf"), ".png", ".tif");
  expect_fit_refused(p("btf"), "",
                     {p("btf") + " holds 30 TIFF images (.tif) and no image btfgmm reads",
                      "their names are BTF image names", "only the format is wrong",
                      "btfgmm reads PNG (8- or 16-bit), JPEG and OpenEXR",
                      "find " + p("btf") + " -name '*.tif' -execdir mogrify -format png {} +"});
  rename_images(p("btf"), ".tif", ".bmp");
  expect_refused(run("info " + p("btf")), {"30 BMP images (.bmp)", "only the format is wrong"});
}

TEST_F(BadInput, ArchiveOrImageGivenAsAModelOrAsData) {
  // The first bytes of a .tar.gz, a zip and an OpenEXR image.
  write_bytes(p("c.tar.gz"), std::string("\x1f\x8b\x08\x00", 4) + std::string(600, '\0'));
  expect_model_refused(p("c.tar.gz"),
                       {"'" + p("c.tar.gz") + "' is a gzip archive, not a btfgmm model",
                        "extract it and fit the BTF images it holds (a folder of images), "
                        "then give the model file here"});
  write_bytes(p("b.btfgmm"), std::string("PK\x03\x04", 4) + std::string(600, '\0'));
  expect_model_refused(p("b.btfgmm"), {"is a zip archive, not a btfgmm model",
                                       "fit a model to '" + p("b.btfgmm") + "'"});
  write_bytes(p("e.btfgmm"), std::string("\x76\x2f\x31\x01", 4) + std::string(600, '\0'));
  expect_model_refused(p("e.btfgmm"), {"is an OpenEXR image, not a btfgmm model"});
  // The archive given as the data to fit.
  expect_fit_refused(p("c.tar.gz"), "",
                     {p("c.tar.gz") + " is a gzip archive, not a BTF",
                      "extract it and give the folder of images it holds"});
}

TEST_F(BadInput, FolderGivenAsAModel) {
  generate();
  const std::string fit_it = "fit a model to it first, then give the model file here";
  expect_refused(run("decode " + p("btf") + " -o " + p("dec")),
                 {"'" + p("btf") + "' is a folder of images, not a model", fit_it});
  EXPECT_FALSE(fs::exists(p("dec")));
  expect_refused(run("eval " + p("btf") + " --x 1 --y 2 --light 30,0 --view 0,0"), {fit_it});
  expect_refused(run("render " + p("btf") + " --compare " + p("btf") + " -o " + p("r.png")),
                 {"--compare needs a model"});
}

TEST_F(BadInput, CompareArgumentsSwapped) {
  fit();
  expect_refused(run("compare " + p("m.btfgmm") + " " + p("btf")),
                 {"the arguments are in the wrong order", "give the BTF first, then the models",
                  "btfgmm compare " + p("btf") + " " + p("m.btfgmm")});
  expect_refused(
      run("compare " + p("m.btfgmm") + " " + p("m.btfgmm")),
      {p("m.btfgmm") + " is a btfgmm model, not a BTF", "the model's provenance names it"});
  // A model given to fit as its data: the way to go on fitting it is shown.
  expect_refused(run("fit " + p("m.btfgmm") + " -o " + p("n.btfgmm")),
                 {"is a btfgmm model, not a BTF",
                  "give " + p("m.btfgmm") +
                      " to the option --continue, the iterations in all to --iterations and a "
                      "new model file to --output"});
  // The BTF twice: the second is no model, and the fit that makes one is shown.
  expect_refused(run("compare " + p("btf") + " " + p("btf")),
                 {"is a folder of images, not a model", "fit a model to it first"});
}

TEST_F(BadInput, RenderOutputInAFormatNotWritten) {
  fit();
  const CliRun r = run("render " + p("m.btfgmm") + " --size 16x16 -o " + p("r.tif"));
  expect_refused(r, {"cannot write the image '" + p("r.tif") + "'",
                     "give a name ending in .png, .jpg (or .jpeg) or .exr"});
  EXPECT_EQ(r.out.find("lit pixels"), std::string::npos) << "refused after rendering: " << r.out;
  EXPECT_FALSE(fs::exists(p("r.tif")));
}

TEST_F(BadInput, UnknownMaterialBeforeAnyWork) {
  const CliRun r = run("generate --material lether -o " + p("x"));
  expect_refused(
      r, {"unknown material 'lether' (did you mean 'leather'?)", "corduroy, knit, bumps, leather"});
  EXPECT_EQ(r.out.find("generating"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(p("x")));
}

TEST_F(BadInput, MistypedOptionOrCommand) {
  generate();
  CliRun r = run("fit " + p("btf") + " --itterations 3 -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 2) << r.out;
  expect_refused(r, {"fit: unknown option '--itterations' (did you mean '--iterations'?)",
                     "'btfgmm fit --help' lists its options"});
  EXPECT_FALSE(fs::exists(p("m.btfgmm")));
  r = run("render " + p("btf") + " --sise=64x64 -o " + p("r.png"));
  expect_refused(r, {"render: unknown option '--sise' (did you mean '--size'?)"});
  r = run("fitt " + p("btf"));
  EXPECT_EQ(r.status, 2) << r.out;
  expect_refused(r, {"unknown command 'fitt' (did you mean 'fit'?)", "generate, info, fit"});
  expect_refused(run("info " + p("btf") + " --jsn"), {"did you mean '--json'?"});
  r = run("--versoin");
  EXPECT_EQ(r.status, 2) << r.out;
  expect_refused(r, {"unknown option '--versoin' (did you mean '--version'?)",
                     "'btfgmm --help' lists the options and commands"});
}

TEST_F(BadInput, NumbersOutOfRangeAndMethodsByPrefixInPlainWords) {
  generate();
  CliRun r = run("fit " + p("btf") + " -M 0 -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 2) << r.out;
  expect_refused(r, {"--components 0: out of range; give a whole number from 1 to 100000"});
  EXPECT_EQ(r.out.find("Run with --help"), std::string::npos) << "CLI11's own text: " << r.out;
  r = run("fit " + p("btf") + " --iterations many -o " + p("m.btfgmm"));
  EXPECT_EQ(r.status, 2) << r.out;
  expect_refused(r, {"--iterations many: not a number; give a whole number from 1 to"});
  r = run("fit " + p("btf") + " --method pca -o " + p("m.btfgmm"));
  expect_refused(r, {"unknown method 'pca' (did you mean 'pca-btf' or 'pca-rf'?)"});
  r = run("fit " + p("btf") + " --method PCA-BTF -o " + p("m.btfgmm"));
  expect_refused(r, {"unknown method 'PCA-BTF' (did you mean 'pca-btf'?)"});
  EXPECT_FALSE(fs::exists(p("m.btfgmm")));
}

TEST_F(BadInput, AnOptionTheMethodDoesNotTakeIsRefusedByName) {
  generate();
  const CliRun r = run("fit " + p("btf") + " --method pca-btf --iterations 5 -o " + p("m.btfgmm"));
  expect_refused(r, {"--iterations cannot apply to --method pca-btf, which does not take it",
                     "--iterations is taken by gm, lpca, plm-rf"});
  EXPECT_FALSE(fs::exists(p("m.btfgmm")));
}

// ---- limits before allocation (the library) --------------------------------------------

using btfgmm::test::error_of;

// Runs `f` in a child process limited to 1 GiB of address space: its exit status is 0 when
// f threw a btfgmm::Error without running out of memory, 1 when it threw something else or
// nothing. Not under AddressSanitizer, which needs terabytes of address space.
template <class F>
int under_1_gib(F f) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const rlimit r{rlim_t(1) << 30, rlim_t(1) << 30};
    ::setrlimit(RLIMIT_AS, &r);
    int status = 1;
    try {
      f();
    } catch (const btfgmm::Error& e) {
      status = std::string(e.what()).find("alloc") == std::string::npos ? 0 : 1;
    } catch (...) {
    }
    ::_exit(status);
  }
  int raw = 0;
  ::waitpid(pid, &raw, 0);
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
}

std::vector<std::uint8_t> bytes_of(const std::string& s) {
  return {s.begin(), s.end()};
}

std::string be32(std::uint32_t v) {
  return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}

std::string png_chunk(const std::string& type, const std::string& data) {
  const std::string td = type + data;
  return be32(std::uint32_t(data.size())) + td +
         be32(std::uint32_t(crc32(0, reinterpret_cast<const Bytef*>(td.data()), uInt(td.size()))));
}

TEST(Limits, MemoryIsKnown) {
  const std::uint64_t m = btfgmm::limits::memory_bytes();
  EXPECT_GT(m, std::uint64_t(64) << 20);
  EXPECT_LE(m, std::uint64_t(::sysconf(_SC_PHYS_PAGES)) * std::uint64_t(::sysconf(_SC_PAGESIZE)));
  const std::string msg =
      error_of([&] { btfgmm::limits::check_memory(double(m) * 2, "reading x.png", "fix it"); });
  EXPECT_NE(msg.find("reading x.png needs about"), std::string::npos) << msg;
  EXPECT_NE(msg.find("; fix it"), std::string::npos) << msg;
  EXPECT_NO_THROW(btfgmm::limits::check_memory(1e6, "x", "y"));
}

TEST(Limits, PngClaimingMoreThanItsDataHolds) {
  // 16000 x 16000 RGB (768 MB of pixels) from 11 bytes of deflate: the header alone is
  // plausible, the decoder refuses before allocating.
  const std::string ihdr = be32(16000) + be32(16000) + std::string("\x08\x02\x00\x00\x00", 5);
  const std::string z = std::string("\x78\x9c\x63\x00\x00\x00\x01\x00\x01", 9);
  const auto png = bytes_of("\x89PNG\r\n\x1a\n" + png_chunk("IHDR", ihdr) + png_chunk("IDAT", z) +
                            png_chunk("IEND", ""));
  EXPECT_EQ(btfgmm::decode_image_header(png, "big.png").width, 16000);
  const std::string msg = error_of([&] { btfgmm::decode_image(png, "big.png"); });
  EXPECT_NE(msg.find("big.png claims an image of 16000x16000 pixels, more than its 9 bytes of "
                     "image data can hold"),
            std::string::npos)
      << msg;
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_EQ(under_1_gib([&] { btfgmm::decode_image(png, "big.png"); }), 0);
#endif
}

TEST(Limits, JpegClaimingMoreThanItsDataHolds) {
  std::string jpeg;
  const std::vector<std::uint8_t> grey(8 * 8 * 3, 99);
  stbi_write_jpg_to_func(
      [](void* ctx, void* data, int size) {
        static_cast<std::string*>(ctx)->append(static_cast<const char*>(data), std::size_t(size));
      },
      &jpeg, 8, 8, 3, grey.data(), 90);
  // The frame header (FF C0, length, precision, height, width): 16000 x 16000.
  const std::size_t sof = jpeg.find("\xff\xc0");
  ASSERT_NE(sof, std::string::npos);
  jpeg.replace(sof + 5, 4, std::string("\x3e\x80\x3e\x80", 4));
  const auto bytes = bytes_of(jpeg);
  EXPECT_EQ(btfgmm::decode_image_header(bytes, "big.jpg").height, 16000);
  const std::string msg = error_of([&] { btfgmm::decode_image(bytes, "big.jpg"); });
  EXPECT_NE(msg.find("big.jpg claims an image of 16000x16000 pixels, more than its"),
            std::string::npos)
      << msg;
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_EQ(under_1_gib([&] { btfgmm::decode_image(bytes, "big.jpg"); }), 0);
#endif
}

TEST(Limits, ExrClaimingMoreThanItHolds) {
  // A 4 x 4 EXR whose data window says 16000 x 16000: refused when the pixels are missing,
  // after allocating a band of scanlines, not the whole image.
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_limits_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  btfgmm::write_exr(dir / "a.exr", 4, 4, std::vector<float>(4 * 4 * 3, 0.5f));
  std::string exr = read_bytes(dir / "a.exr");
  fs::remove_all(dir);
  const std::size_t at = exr.find(std::string("dataWindow\0box2i\0", 17));
  ASSERT_NE(at, std::string::npos);
  const std::int32_t window[4] = {0, 0, 15999, 15999};  // xmin, ymin, xmax, ymax
  exr.replace(at + 17 + 4, 16, reinterpret_cast<const char*>(window), 16);
  const auto bytes = bytes_of(exr);
  EXPECT_EQ(btfgmm::decode_image_header(bytes, "big.exr").width, 16000);
  const std::string msg = error_of([&] { btfgmm::decode_image(bytes, "big.exr"); });
  EXPECT_NE(msg.find("big.exr"), std::string::npos) << msg;
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_EQ(under_1_gib([&] { btfgmm::decode_image(bytes, "big.exr"); }), 0);
#endif
}

TEST(Limits, ZipEntryClaimingMoreThanItHolds) {
  const fs::path dir = fs::temp_directory_path() / ("btfgmm_limits_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  btfgmm::write_png(dir / "a.png", 4, 4, std::vector<float>(4 * 4 * 3, 7.0f));
  const std::string png = read_bytes(dir / "a.png");
  const fs::path zip = dir / "m.zip";
  {
    int code = 0;
    zip_t* z = zip_open(zip.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
    ASSERT_NE(z, nullptr);
    zip_source_t* src = zip_source_buffer(z, png.data(), png.size(), 0);
    const zip_int64_t i = zip_file_add(z, "m/00000 tl000 pl000 tv000 pv000.png", src, 0);
    ASSERT_GE(i, 0);
    zip_set_file_compression(z, zip_uint64_t(i), ZIP_CM_DEFLATE, 9);
    ASSERT_EQ(zip_close(z), 0);
  }
  // Patch the uncompressed size, in the local header (offset 22) and the central one (24).
  std::string bytes = read_bytes(zip);
  const std::uint32_t huge = 1500000000u;
  const std::size_t local = bytes.find("PK\x03\x04"), central = bytes.find("PK\x01\x02");
  ASSERT_NE(local, std::string::npos);
  ASSERT_NE(central, std::string::npos);
  bytes.replace(local + 22, 4, reinterpret_cast<const char*>(&huge), 4);
  bytes.replace(central + 24, 4, reinterpret_cast<const char*>(&huge), 4);
  write_bytes(zip, bytes);
  const std::string msg = error_of([&] { btfgmm::BtfSource::open(zip); });
  fs::remove_all(dir);
  EXPECT_NE(msg.find("m.zip:m/00000 tl000 pl000 tv000 pv000.png claims 1500000000 bytes "
                     "uncompressed"),
            std::string::npos)
      << msg;
  EXPECT_NE(msg.find("download it again"), std::string::npos) << msg;
}

TEST(Limits, BtfBeyondMemory) {
  const std::string msg = error_of([] {
    btfgmm::Btf b(btfgmm::DirectionSet::ubo81(), btfgmm::DirectionSet::ubo81(), 65536, 65536,
                  btfgmm::SampleFormat::kLdr8);
  });
  EXPECT_NE(msg.find("a BTF of 6561 images of 65536x65536 pixels needs about"), std::string::npos)
      << msg;
  EXPECT_NE(msg.find("use a smaller tile"), std::string::npos) << msg;
}

// A small model's bytes with a field changed and the CRC made right again.
std::vector<std::uint8_t> patched_model(std::size_t offset, const void* value, std::size_t n) {
  btfgmm::BtfModel m;
  m.lights = btfgmm::DirectionSet({{0, 0}, {30, 90}});
  m.views = btfgmm::DirectionSet({{0, 0}});
  m.width = m.height = 4;
  m.origin = {.x = 0, .y = 0, .width = 4, .height = 4};
  m.mixture.resize(1);
  m.mixture.weight[0] = 1.0;
  m.mixture.mean[0].fill(0.5);
  m.mixture.var[0].fill(1.0);
  m.mean_brdf.assign(2 * 1 * 3, 10.0f);
  std::vector<std::uint8_t> b = btfgmm::serialize_model(m);
  EXPECT_NO_THROW(btfgmm::deserialize_model(b, "ok.btfgmm"));
  std::memcpy(b.data() + offset, value, n);
  const auto crc = std::uint32_t(crc32(0, b.data(), uInt(b.size() - 4)));
  std::memcpy(b.data() + b.size() - 4, &crc, 4);
  return b;
}

TEST(Limits, ModelTileAndOriginOutOfRange) {
  // The payload starts at byte 24 with the method tag (u32 2, "gm"), then the provenance's
  // size (u32 0: none recorded), width, height (u32) at byte 34, origin x, y (i32) at byte 42.
  const std::uint32_t big[2] = {65536, 65536};
  std::string msg =
      error_of([&] { btfgmm::deserialize_model(patched_model(34, big, 8), "big.btfgmm"); });
  EXPECT_NE(msg.find("'big.btfgmm' is invalid: tile size 65536x65536 is out of range"),
            std::string::npos)
      << msg;
  const std::int32_t far[2] = {2147483647, 0};
  msg = error_of([&] { btfgmm::deserialize_model(patched_model(42, far, 8), "far.btfgmm"); });
  EXPECT_NE(msg.find("origin (2147483647, 0) is outside any image"), std::string::npos) << msg;
  const std::int32_t negative[2] = {0, -1};
  msg = error_of([&] { btfgmm::deserialize_model(patched_model(42, negative, 8), "n.btfgmm"); });
  EXPECT_NE(msg.find("origin (0, -1)"), std::string::npos) << msg;
}

// A payload size near the top of the 64-bit range: refused, and the message gives both sizes
// as they are (a sum of the header's size and the claimed payload wrapped around).
TEST(Limits, ModelPayloadSizeNearTwoToThe64) {
  const std::uint64_t huge = ~std::uint64_t(0);
  const auto bytes = patched_model(16, &huge, 8);  // the header's payload size, after version
  const std::string msg = error_of([&] { btfgmm::deserialize_model(bytes, "p.btfgmm"); });
  EXPECT_NE(msg.find(fmt::format("model file 'p.btfgmm' is {} bytes, a payload of {}, but its "
                                 "header says a payload of 18446744073709551615 bytes",
                                 bytes.size(), bytes.size() - 28)),
            std::string::npos)
      << msg;
}

// The compact encoding's codes (a zstd frame) claiming 5 * 10^11 bytes from 17: refused
// before anything is allocated for them. The golden version-5 file ends its payload with the
// component count (u32), five quantisation steps (f64), the coded size (u64) and the frame.
TEST(Limits, CompactCodesClaimingMoreThanTheyHold) {
  std::string b = read_bytes(fs::path(BTFGMM_TEST_DATA) / "golden_v5_gm.btfgmm");
  const std::size_t frame = b.rfind("\x28\xb5\x2f\xfd");
  ASSERT_NE(frame, std::string::npos);
  const std::uint32_t count = ~std::uint32_t(0);
  const std::uint64_t claimed = 500000000000;
  b.replace(frame - 52, 4, reinterpret_cast<const char*>(&count), 4);
  b.replace(frame - 8, 8, reinterpret_cast<const char*>(&claimed), 8);
  // The frame: magic, a single segment with an 8-byte content size, one last RLE block.
  b.resize(frame);
  b += std::string("\x28\xb5\x2f\xfd\xe0", 5) +
       std::string(reinterpret_cast<const char*>(&claimed), 8) + std::string("\x03\x00\x10\x07", 4);
  b += std::string(4, '\0');  // the CRC-32, below
  const std::uint64_t payload = b.size() - 28;
  b.replace(16, 8, reinterpret_cast<const char*>(&payload), 8);
  std::vector<std::uint8_t> bytes(b.begin(), b.end());
  const auto crc = std::uint32_t(crc32(0, bytes.data(), uInt(bytes.size() - 4)));
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  const std::string msg = error_of([&] { btfgmm::deserialize_model(bytes, "z.btfgmm"); });
  EXPECT_NE(msg.find("'z.btfgmm' is invalid: the compressed codes claim 500000000000 bytes, "
                     "more than their 17 bytes can hold"),
            std::string::npos)
      << msg;
}

}  // namespace
