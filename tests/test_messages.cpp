// What the library tells a user who went wrong or waits: the nearest name to a mistyped one and
// the progress of a long generation.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/utia.hpp"
#include "btfgmm/synth/generate.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using test::error_of;

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

  // namespace
}  // namespace btfgmm
