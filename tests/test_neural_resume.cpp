// The neural BTF fit's checkpoints (methods/neural_btf_checkpoint.hpp): a fit stopped at any
// step, or saved at an epoch's end, and resumed through the file writes the model the
// uninterrupted fit writes, bit for bit; the file is refused truncated, damaged or for another
// tile; the command saves, stops, resumes and removes the checkpoint.
#include <gtest/gtest.h>
#include <zlib.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/measure/seamless_tile.hpp"
#include "btfgmm/methods/neural_btf_checkpoint.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/synth/generate.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

Btf small_tile() {
  return test::generated_tile("knit", 8, 1, "rings:0/1,30/4,60/6", "rings:0/1,45/5");
}

FitOptions options(int epochs) {
  FitOptions s = test::small_neural_options(epochs);
  s.seed = 3;
  return s;
}

// The model's parameters as its file stores them.
std::vector<std::uint8_t> payload(const Representation& m) {
  return m.payload();
}

// The states a fit saves (every epoch, and where it is stopped at report `stop_at`).
struct Saved {
  std::vector<NeuralFitState> states;
  std::unique_ptr<Representation> model;
};

Saved fit_saving(const Btf& tile, int epochs, int stop_at) {
  Saved out;
  std::atomic<bool> stop{false};
  FitOptions s = options(epochs);
  int reports = 0;
  s.stop = &stop;
  s.progress = [&](double, std::string_view) {
    if (++reports == stop_at) stop = true;
  };
  NeuralCheckpointing c{.every_epochs = 1,
                        .save = [&](const NeuralFitState& k) { out.states.push_back(k); },
                        .resume = nullptr};
  out.model = fit_neural_btf(tile, s, c);
  return out;
}

// The checkpoint of a fit of the 8 x 8 `tile` of `input` to `output` (options(6)) as a fit
// stopped after its 6th report leaves it.
NeuralCheckpoint stopped_checkpoint(const std::string& input, const std::string& output,
                                    const Btf& tile) {
  NeuralCheckpoint k;
  k.input = input;
  k.output = output;
  k.tile = {.x = 0, .y = 0, .width = 8, .height = 8};
  k.options = options(6);
  k.data_fingerprint = btf_fingerprint(tile);
  k.state = fit_saving(tile, 6, 6).states.back();
  return k;
}

// The state through a checkpoint file and back, as the command saves and reads it.
NeuralFitState through_a_file(const NeuralFitState& state, const std::string& tag) {
  NeuralCheckpoint k;
  k.input = "in";
  k.output = "out.btfgmm";
  k.tile = {.x = 0, .y = 0, .width = 8, .height = 8};
  k.options = options(1);
  k.state = state;
  const fs::path path = fs::temp_directory_path() / ("btfgmm_neural_" + tag + ".ckpt");
  save_neural_checkpoint(k, path);
  const NeuralCheckpoint back = load_neural_checkpoint(path);
  fs::remove(path);
  return back.state;
}

std::unique_ptr<Representation> resume(const Btf& tile, int epochs, const NeuralFitState& k) {
  NeuralCheckpointing c{.every_epochs = 1, .save = {}, .resume = &k};
  return fit_neural_btf(tile, options(epochs), c);
}

TEST(NeuralResume, AStoppedFitResumedIsTheUninterruptedFitBitForBit) {
  const Btf tile = small_tile();
  const int epochs = 6;
  const Saved whole = fit_saving(tile, epochs, 0);
  ASSERT_EQ(whole.states.size(), std::size_t(epochs - 1));  // after every epoch but the last
  const auto want = payload(*whole.model);
  // Stops after the 1st, 6th and 13th report (within epochs 1, 2 and 4; four reports an
  // epoch), each resumed from the state saved at the stop.
  for (const int stop_at : {1, 6, 13}) {
    const Saved cut = fit_saving(tile, epochs, stop_at);
    ASSERT_FALSE(cut.states.empty());
    const NeuralFitState& at_stop = cut.states.back();
    EXPECT_TRUE(at_stop.validation_due);
    const auto resumed = resume(tile, epochs, through_a_file(at_stop, "stop"));
    EXPECT_EQ(payload(*resumed), want) << "stopped at report " << stop_at;
    EXPECT_TRUE(resumed->provenance().fit.settings.empty()) << "a whole fit records no stop";
  }
  // From each epoch's end.
  for (std::size_t e = 0; e < whole.states.size(); e += 2) {
    EXPECT_EQ(whole.states[e].epoch, int(e) + 1);
    EXPECT_EQ(payload(*resume(tile, epochs, through_a_file(whole.states[e], "epoch"))), want)
        << "from the end of epoch " << e + 1;
  }
}

TEST(NeuralResume, AStateOfAnotherShapeOrPastTheFitIsRefused) {
  const Btf tile = small_tile();
  const Saved whole = fit_saving(tile, 3, 0);
  ASSERT_FALSE(whole.states.empty());
  FitOptions wider = options(3);
  wider.width = 17;
  NeuralCheckpointing c{.every_epochs = 1, .save = {}, .resume = &whole.states[0]};
  EXPECT_NE(test::error_of([&] { fit_neural_btf(tile, wider, c); }).find("parameters where"),
            std::string::npos);
  NeuralFitState past = whole.states[0];
  past.epoch = 9;
  c.resume = &past;
  EXPECT_NE(test::error_of([&] { fit_neural_btf(tile, options(3), c); }).find("outside the fit"),
            std::string::npos);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(NeuralResume, ATruncatedOrDamagedCheckpointIsRefusedByName) {
  const Btf tile = small_tile();
  const Saved whole = fit_saving(tile, 2, 0);
  NeuralCheckpoint k;
  k.input = "in";
  k.output = "out.btfgmm";
  k.tile = {.x = 0, .y = 0, .width = 8, .height = 8};
  k.options = options(2);
  k.data_fingerprint = btf_fingerprint(tile);
  k.state = whole.states.at(0);
  const fs::path path = fs::temp_directory_path() / "btfgmm_neural_damaged.ckpt";
  save_neural_checkpoint(k, path);
  EXPECT_TRUE(is_neural_checkpoint_file(path));
  const std::string bytes = slurp(path);
  const NeuralCheckpoint back = load_neural_checkpoint(path);
  EXPECT_EQ(back.state.theta, k.state.theta);
  EXPECT_EQ(back.state.second_moment, k.state.second_moment);
  EXPECT_EQ(back.options.width, 16u);
  EXPECT_EQ(back.data_fingerprint, k.data_fingerprint);
  for (std::size_t n : {std::size_t(0), std::size_t(9), bytes.size() / 2, bytes.size() - 1}) {
    std::ofstream(path, std::ios::binary) << bytes.substr(0, n);
    EXPECT_NE(test::error_of([&] { load_neural_checkpoint(path); }).find(path.string()),
              std::string::npos)
        << "prefix " << n;
  }
  for (std::size_t i = 0; i < bytes.size(); i += 13) {
    std::string bad = bytes;
    bad[i] = char(bad[i] ^ 0x20);
    std::ofstream(path, std::ios::binary) << bad;
    EXPECT_THROW(load_neural_checkpoint(path), Error) << "byte " << i;
  }
  // The fuzz target's seed (tests/fuzz/corpus/fuzz_neural_checkpoint) is a checkpoint.
  const NeuralCheckpoint seed = load_neural_checkpoint(
      fs::path(BTFGMM_TEST_DATA) / "../fuzz/corpus/fuzz_neural_checkpoint/seed_small.ckpt");
  EXPECT_EQ(seed.state.theta.size(), 71u);  // 2 x 2 texels x L = 2, and 11-4-3 weights
  EXPECT_EQ(seed.options.width, 4u);
  // What the fuzz target found (with the CRC-32 made right, as the target reads it): the
  // held-out check's flag 17, read as "due" and written back as 1.
  std::string found = slurp(fs::path(BTFGMM_TEST_DATA) /
                            "../fuzz/corpus/fuzz_neural_checkpoint/flag_neither_0_nor_1.ckpt");
  ASSERT_GT(found.size(), 16u);
  const auto crc = std::uint32_t(
      crc32(0L, reinterpret_cast<const Bytef*>(found.data()), uInt(found.size() - 4)));
  std::memcpy(found.data() + found.size() - 4, &crc, 4);
  EXPECT_NE(test::error_of([&] {
              read_neural_checkpoint(
                  std::span(reinterpret_cast<const std::uint8_t*>(found.data()), found.size()),
                  "found.ckpt");
            }).find("neither 0 nor 1"),
            std::string::npos);
  // The mixture's checkpoint is not a neural one, nor the reverse.
  FitCheckpoint mixture;
  save_checkpoint(mixture, path);
  EXPECT_FALSE(is_neural_checkpoint_file(path));
  EXPECT_NE(test::error_of([&] { load_neural_checkpoint(path); }).find("not a neural fit's"),
            std::string::npos);
  save_neural_checkpoint(k, path);
  EXPECT_THROW(load_checkpoint(path), Error);
  fs::remove(path);
}

#ifdef BTFGMM_CLI_PATH
// The command: a fit with --checkpoint writes the model of one without and removes the
// checkpoint; `fit --resume` of a stopped fit's state writes the uninterrupted fit's model
// and removes the checkpoint; a resume on other data, or with another size, is refused; the
// checkpoint may not be the model. (tests/sigint_check.py stops the command itself.)
TEST(NeuralResume, TheCommandStopsAndResumesToTheSameModel) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_neural_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string btf = (dir / "btf").string(), ck = (dir / "fit.ck").string();
  using test::run_cli;
  ASSERT_EQ(run_cli("generate --material knit --size 8 --lights rings:0/1,30/4,60/6 --views "
                    "rings:0/1,45/5 -q -o " +
                        btf,
                    "nr")
                .status,
            0);
  const std::string fit = "fit " + btf + " --method neural -M 4 --width 16 --iterations 6 ";
  ASSERT_EQ(run_cli(fit + "-q -o " + (dir / "whole.btfgmm").string(), "nr").status, 0);
  // Every epoch's checkpoint, the last one's kept by copying it before the fit removes it.
  const test::CliRun saved =
      run_cli(fit + "--checkpoint " + ck + " -o " + (dir / "saved.btfgmm").string(), "nr");
  ASSERT_EQ(saved.status, 0) << saved.err;
  EXPECT_FALSE(fs::exists(ck)) << "the checkpoint is removed once the model is written";
  EXPECT_EQ(load_representation(dir / "saved.btfgmm")->payload(),
            load_representation(dir / "whole.btfgmm")->payload());
  // A checkpoint through the library, as a stopped fit leaves it, resumed by the command.
  const Btf tile = small_tile();
  NeuralCheckpoint k = stopped_checkpoint(btf, (dir / "resumed.btfgmm").string(), tile);
  save_neural_checkpoint(k, ck);
  const std::string copy = slurp(ck);
  EXPECT_NE(run_cli("fit --resume " + ck + " -M 8", "nr").err.find("--components"),
            std::string::npos);
  const test::CliRun resumed = run_cli("fit --resume " + ck, "nr");
  ASSERT_EQ(resumed.status, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("resuming from"), std::string::npos) << resumed.err;
  EXPECT_FALSE(fs::exists(ck));
  const auto whole = load_representation(dir / "resumed.btfgmm");
  EXPECT_EQ(whole->payload(),
            fit_and_record(find_method("neural"), tile, options(6), {})->payload());
  EXPECT_EQ(whole->provenance().fit.runs, 2u);
  // Other data under the input's name: refused, the checkpoint kept.
  std::ofstream(ck, std::ios::binary) << copy;
  ASSERT_EQ(run_cli("generate --material knit --size 8 --seed 2 --lights rings:0/1,30/4,60/6 "
                    "--views rings:0/1,45/5 -q --overwrite -o " +
                        btf,
                    "nr")
                .status,
            0);
  const test::CliRun other = run_cli("fit --resume " + ck, "nr");
  EXPECT_NE(other.status, 0);
  EXPECT_NE(other.err.find("is not what checkpoint"), std::string::npos) << other.err;
  EXPECT_TRUE(fs::exists(ck));
  // The checkpoint is a file of its own; a whole fit leaves no stale state of an earlier stop.
  EXPECT_NE(run_cli(fit + "--checkpoint " + (dir / "m.btfgmm").string() + " -o " +
                        (dir / "m.btfgmm").string(),
                    "nr")
                .err.find("is the fit's model"),
            std::string::npos);
  std::ofstream(dir / "m.btfgmm.ckpt", std::ios::binary) << copy;
  ASSERT_EQ(run_cli(fit + "-q -o " + (dir / "m.btfgmm").string(), "nr").status, 0);
  EXPECT_FALSE(fs::exists(dir / "m.btfgmm.ckpt"));
  // Another method takes no checkpoint.
  EXPECT_NE(run_cli("fit " + btf + " --method pca-btf --checkpoint " + ck + " -o " +
                        (dir / "pca.btfgmm").string(),
                    "nr")
                .err.find("--checkpoint"),
            std::string::npos);
  fs::remove_all(dir);
}

// A checkpoint of a fit of a made seamless tile names it, and the command's resume makes the
// tile again from the input: the model is the uninterrupted fit's of the made tile.
TEST(NeuralResume, AMadeTileIsMadeAgainOnResume) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_neural_made_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string btf = (dir / "btf").string(), ck = (dir / "fit.ck").string();
  ASSERT_EQ(test::run_cli("generate --material bumps --size 12 --lights rings:0/1,30/4,60/6 "
                          "--views rings:0/1,45/5 -q -o " +
                              btf,
                          "nm")
                .status,
            0);
  const BtfSource src = BtfSource::open(btf);
  SeamlessTileConfig c;
  c.width = c.height = 8;
  const SeamlessTile made = cut_seamless_tile(src, c);
  const Btf tile = seamless_tile_source(src, made).load();
  NeuralCheckpoint k = stopped_checkpoint(btf, (dir / "resumed.btfgmm").string(), tile);
  k.made_from = made.describe();
  save_neural_checkpoint(k, ck);
  EXPECT_EQ(load_neural_checkpoint(ck).made_from, made.describe());
  const test::CliRun resumed = test::run_cli("fit --resume " + ck, "nm");
  ASSERT_EQ(resumed.status, 0) << resumed.err;
  const auto whole = load_representation(dir / "resumed.btfgmm");
  EXPECT_EQ(whole->payload(),
            fit_and_record(find_method("neural"), tile, options(6), {})->payload());
  bool named = false;
  for (const auto& [setting, value] : whole->provenance().fit.settings)
    named = named || (setting == "tile" && value == made.describe());
  EXPECT_TRUE(named) << "the model's provenance names the made tile";
  fs::remove_all(dir);
}
#endif

}  // namespace
}  // namespace btfgmm
