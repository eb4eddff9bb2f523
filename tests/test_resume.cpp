// Checkpoints and resumed fits: a fit interrupted at any point and resumed ends with the model
// an uninterrupted fit writes, bit for bit.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <thread>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/provenance.hpp"
#include "btfgmm/model/samples.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

Btf small_generated() {
  GenerateConfig g;
  g.size = 8;
  g.lights = DirectionSet::parse("rings:0/1,30/4,60/6");
  g.views = DirectionSet::parse("rings:0/1,45/5");
  return generate(g);
}

TEST(Resume, InterruptedAndResumedFitEqualsUninterrupted) {
  const Btf btf = small_generated();
  const SampleSet s = make_sample_set(btf);
  const ProductMixture start = initial_mixture(s, 12, 5);
  EmConfig c;
  c.max_iterations = 9;
  ProductMixture whole = start;
  const EmResult full = fit_em(s, whole, c);
  for (int stop_at = 1; stop_at < 9; ++stop_at) {
    std::atomic<bool> stop{false};
    EmConfig cs = c;
    cs.stop = &stop;
    ProductMixture part = start;
    const EmResult first =
        fit_em(s, part, cs, {}, nullptr, [&](const ProductMixture&, const EmResult& r) {
          if (r.iterations == stop_at) stop = true;
        });
    ASSERT_TRUE(first.interrupted);
    ASSERT_EQ(first.iterations, stop_at);
    // Through a checkpoint file, as the command does.
    FitCheckpoint k;
    k.input = "in";
    k.output = "out";
    k.state = {part, first};
    const fs::path path = fs::temp_directory_path() / "btfgmm_resume_test.ckpt";
    save_checkpoint(k, path);
    const FitCheckpoint back = load_checkpoint(path);
    fs::remove(path);
    ProductMixture resumed = back.state.mixture;
    const EmResult rest = fit_em(s, resumed, c, {}, &back.state.result);
    EXPECT_FALSE(rest.interrupted);
    EXPECT_EQ(rest.log_likelihood, full.log_likelihood) << "stopped at " << stop_at;
    EXPECT_EQ(rest.final_log_likelihood, full.final_log_likelihood);
    ASSERT_EQ(resumed.size(), whole.size());
    for (std::size_t m = 0; m < whole.size(); ++m) {
      EXPECT_EQ(resumed.weight[m], whole.weight[m]);
      EXPECT_EQ(resumed.mean[m], whole.mean[m]);
      EXPECT_EQ(resumed.var[m], whole.var[m]);
    }
  }
}

TEST(Resume, CheckpointRejectsTruncationAndCorruption) {
  const Btf btf = small_generated();
  const SampleSet s = make_sample_set(btf);
  FitCheckpoint k;
  k.input = "btf";
  k.output = "m.btfgmm";
  k.tile = {.x = 0, .y = 0, .width = 8, .height = 8};
  k.data_fingerprint = btf_fingerprint(btf);
  k.state.mixture = initial_mixture(s, 3, 1);
  k.state.result.iterations = 2;
  k.state.result.log_likelihood = {-3.0, -2.0};
  const fs::path path = fs::temp_directory_path() / "btfgmm_ckpt_corrupt.ckpt";
  save_checkpoint(k, path);
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const FitCheckpoint back = load_checkpoint(path);
  EXPECT_EQ(back.input, "btf");
  EXPECT_EQ(back.tile.width, 8);
  EXPECT_EQ(back.data_fingerprint, k.data_fingerprint);
  EXPECT_EQ(back.state.mixture.mean, k.state.mixture.mean);
  for (std::size_t n : {std::size_t(0), std::size_t(10), bytes.size() / 2, bytes.size() - 1}) {
    std::ofstream(path, std::ios::binary) << bytes.substr(0, n);
    EXPECT_THROW(load_checkpoint(path), Error) << "prefix " << n;
  }
  for (std::size_t i = 0; i < bytes.size(); i += 7) {
    std::string bad = bytes;
    bad[i] = char(bad[i] ^ 0x20);
    std::ofstream(path, std::ios::binary) << bad;
    EXPECT_THROW(load_checkpoint(path), Error) << "byte " << i;
  }
  fs::remove(path);
  // The fingerprint sees a changed value.
  Btf other = btf;
  other.data()[5] += 1.0f;
  EXPECT_NE(btf_fingerprint(other), btf_fingerprint(btf));
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// A model file less what depends on when, how fast and in how many runs its fit ran: its
// method and payload, and its provenance's data, settings, and every iteration's L and
// components (not their times, nor the fit's time and runs).
std::string timeless(const std::string& file) {
  const std::span bytes(reinterpret_cast<const std::uint8_t*>(file.data()), file.size());
  const ModelFileContents c = open_model_file(bytes, "model");
  std::string out = c.method + std::to_string(c.flags) + "|" +
                    std::string(c.payload.begin(), c.payload.end()) + "|";
  const Provenance& p = c.provenance;
  out += p.data.source.name + " " + std::to_string(p.data.source.image_width) + "x" +
         std::to_string(p.data.source.image_height) + " " + hash_text(p.data.content_hash);
  for (const auto& [k, v] : p.fit.settings) out += " " + k + "=" + v;
  for (const IterationRecord& it : p.fit.iterations) {
    char l[64];
    std::snprintf(l, sizeof l, " %.17g/%u", it.log_likelihood, it.components);
    out += l;
  }
  return out;
}

int run_cli(const std::string& args) {
  const std::string cmd = std::string(BTFGMM_CLI_PATH) + " " + args + " > /dev/null 2>&1";
  const int raw = std::system(cmd.c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

// Starts `btfgmm fit ...` and kills it with `sig` once its checkpoint holds at least
// `iteration` iterations (read back with load_checkpoint, polled every millisecond), so that
// the kill lands inside the fit whatever the machine's load; returns its exit status.
int start_and_kill(const std::vector<std::string>& args, const fs::path& checkpoint, int iteration,
                   int sig) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(BTFGMM_CLI_PATH));
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (!freopen("/dev/null", "w", stderr)) _exit(126);
    execv(BTFGMM_CLI_PATH, argv.data());
    _exit(127);
  }
  int status = 0;
  for (int i = 0; i < 60000; ++i) {
    if (waitpid(pid, &status, WNOHANG) == pid) return status;  // finished (or failed) first
    if (fs::exists(checkpoint)) {
      try {
        if (load_checkpoint(checkpoint).state.result.iterations >= iteration) break;
      } catch (const Error&) {
        // Replaced while read: the next poll sees the new one.
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  kill(pid, sig);
  waitpid(pid, &status, 0);
  return status;
}

// The command, killed with SIGKILL at several moments and resumed, writes the model an
// uninterrupted fit writes (bit for bit but for the provenance's times and runs); SIGINT
// saves the state itself and exits with 130.
TEST(Resume, KilledCommandResumesToTheSameModel) {
  const fs::path dir =
      fs::temp_directory_path() / ("btfgmm_kill_resume_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string btf = (dir / "btf").string();
  ASSERT_EQ(run_cli("generate --size 10 --lights rings:0/1,30/6,60/8 --views rings:0/1,30/6,60/8 "
                    "-o " +
                    btf),
            0);
  // Enough work (about half a second here) that a kill can land between any two iterations.
  const std::string common = " -M 200 --iterations 200 --seed 3 -q ";
  ASSERT_EQ(run_cli("fit " + btf + common + "-o " + (dir / "full.btfgmm").string()), 0);
  const std::string full = timeless(slurp(dir / "full.btfgmm"));
  ASSERT_FALSE(full.empty());
  int resumed = 0, identical = 0;
  const int points = 8;
  for (int k = 0; k < points; ++k) {
    const fs::path model = dir / ("cut" + std::to_string(k) + ".btfgmm");
    const fs::path ckpt = dir / ("cut" + std::to_string(k) + ".ckpt");
    // Kill points spread over the first two thirds of the 200 iterations.
    const int iteration = 1 + 2 * 200 * k / (3 * points);
    const int sig = k % 4 == 3 ? SIGINT : SIGKILL;
    const int status =
        start_and_kill({"fit", btf, "-M", "200", "--iterations", "200", "--seed", "3", "-q", "-o",
                        model.string(), "--checkpoint", ckpt.string()},
                       ckpt, iteration, sig);
    if (sig == SIGINT && WIFEXITED(status)) {
      EXPECT_TRUE(WEXITSTATUS(status) == 130 || WEXITSTATUS(status) == 0);
      if (WEXITSTATUS(status) == 130) {
        EXPECT_TRUE(fs::exists(ckpt));
      }
    }
    if (fs::exists(ckpt)) {
      // A model under the target name is only ever a whole one.
      if (fs::exists(model)) {
        EXPECT_EQ(timeless(slurp(model)), full);
      }
      ASSERT_EQ(run_cli("fit --resume " + ckpt.string() + " -q"), 0);
      ++resumed;
      EXPECT_FALSE(fs::exists(ckpt)) << "the checkpoint is removed once the model is written";
    } else if (!fs::exists(model)) {
      // Killed before the first checkpoint: start again.
      ASSERT_EQ(run_cli("fit " + btf + common + "-o " + model.string()), 0);
    }
    identical += timeless(slurp(model)) == full;
  }
  std::printf(
      "kill-and-resume: %d kill points, %d resumed from a checkpoint, %d identical to "
      "the uninterrupted model\n",
      points, resumed, identical);
  EXPECT_EQ(identical, points);
  EXPECT_EQ(resumed, points);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace btfgmm
