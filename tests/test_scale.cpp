// Fits that outgrow one machine: the compact sample set (8-bit data held as bytes, the
// residuals computed where they are used) and the fit split over processes.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <span>
#include <thread>
#include <vector>

#include <filesystem>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/provenance.hpp"
#include "btfgmm/model/samples.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;

// A generated 8-bit BTF of 12 x 12 pixels and 7 x 7 directions written to the folder btf/ of a
// new temporary folder (returned; outputs go beside btf/, never into it).
fs::path written_btf(const std::string& tag, bool hdr = false) {
  const fs::path base =
      fs::temp_directory_path() / ("btfgmm_scale_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(base);
  const fs::path dir = base / "btf";
  GenerateConfig g;
  g.material = "knit";
  g.size = 12;
  g.seed = 5;
  g.lights = g.views = DirectionSet::parse("rings:0/1,45/6");
  g.supersample = 1;
  g.hdr = hdr;
  write_utia(generate(g), dir);
  return base;
}

// Read image by image, an 8-bit tile is held as 3 bytes a sample, and is the sample set of the
// tile loaded whole: the same levels, mean BRDF and residuals (bit for bit), the same content
// hash.
TEST(Scale, SampleSetReadImageByImageHoldsBytesAndEqualsTheLoadedTile) {
  const fs::path dir = written_btf("bytes");
  const BtfSource src = BtfSource::open(dir / "btf");
  const Tile tile{.x = 2, .y = 3, .width = 8, .height = 6};
  std::uint64_t hash = 0;
  const SampleSet read = read_sample_set(src, tile, &hash);
  const Btf loaded = src.load(tile);
  const SampleSet whole = make_sample_set(loaded);
  EXPECT_EQ(hash, tile_content_hash(loaded));
  EXPECT_EQ(read.bytes_per_sample(), 3u);
  EXPECT_TRUE(read.residual.empty());
  EXPECT_EQ(read.levels.size(), read.size() * 3);
  EXPECT_EQ(read.levels, whole.levels);
  EXPECT_EQ(read.mean_brdf, whole.mean_brdf);
  EXPECT_EQ(read.scaling.unit, whole.scaling.unit);
  ASSERT_EQ(read.size(), 8u * 6u * 7u * 7u);
  std::size_t checked = 0;
  for (std::size_t p = 0; p < read.pixels(); ++p)
    for (std::size_t l = 0; l < read.lights; ++l)
      for (std::size_t v = 0; v < read.views; ++v)
        for (int c = 0; c < 3; ++c) {
          const int x = int(p % 8), y = int(p / 8);
          const float expected = loaded.at(l, v, x, y, c) - read.mean_brdf[(l * 7 + v) * 3 + c];
          EXPECT_EQ(read.residual_of(p, l, v, c), expected);
          ++checked;
        }
  EXPECT_EQ(checked, read.size() * 3);
  fs::remove_all(dir);
}

// HDR data keeps float residuals, read through the same call, equal to the loaded tile's.
TEST(Scale, HdrSampleSetKeepsFloatResiduals) {
  const fs::path dir = written_btf("hdr", true);
  const BtfSource src = BtfSource::open(dir / "btf");
  std::uint64_t hash = 0;
  const SampleSet read = read_sample_set(src, {}, &hash);
  const Btf loaded = src.load();
  EXPECT_EQ(hash, tile_content_hash(loaded));
  EXPECT_EQ(read.bytes_per_sample(), 12u);
  EXPECT_EQ(read.residual, make_sample_set(loaded).residual);
  fs::remove_all(dir);
}

// ---- The fit over the processes of an MPI job ---------------------------------------------

#if defined(BTFGMM_MPIEXEC) && defined(BTFGMM_CLI_PATH)
// `btfgmm` as `np` processes of an MPI job (allowed to run as root, more processes than cores).
std::string under_mpirun(int np) {
  return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " +
         std::string(BTFGMM_MPIEXEC) + " --oversubscribe -np " + std::to_string(np) + " " +
         BTFGMM_CLI_PATH;
}

// Runs a shell command line; its exit status and what it wrote to stderr.
test::CliRun shell(const std::string& cmd, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  test::CliRun r;
  const int raw = std::system((cmd + " > /dev/null 2> " + err.string()).c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  std::ifstream in(err);
  r.err.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return r;
}

// What of a model file does not depend on when and where its fit ran: the method, flags and
// payload (the parameters), the data's provenance and every iteration's L and components.
std::string model_of_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (file.empty()) return "(missing " + p.string() + ")";
  const std::span bytes(reinterpret_cast<const std::uint8_t*>(file.data()), file.size());
  const ModelFileContents c = open_model_file(bytes, p.string());
  std::string out = c.method + std::to_string(c.flags) + "|" +
                    std::string(c.payload.begin(), c.payload.end()) + "|" +
                    hash_text(c.provenance.data.content_hash);
  for (const IterationRecord& it : c.provenance.fit.iterations) {
    char l[64];
    std::snprintf(l, sizeof l, " %.17g/%u", it.log_likelihood, it.components);
    out += l;
  }
  return out;
}

// Kills (SIGKILL) one process of a running fit, found by its command line: it starts with the
// command's path and names `token`. Returns whether one was found.
bool kill_fit_process(const std::string& token) {
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "cmdline", std::ios::binary);
    const std::string cmd((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (cmd.rfind(std::string(BTFGMM_CLI_PATH) + '\0', 0) != 0) continue;
    if (cmd.find(token) == std::string::npos) continue;
    return ::kill(pid_t(std::stol(name)), SIGKILL) == 0;
  }
  return false;
}

// A fit as 1, 2 and 3 processes of an MPI job writes the model of a fit in one process (with
// 1 or 2 threads), parameters and log-likelihoods bit for bit.
TEST(Scale, MpiJobsOfOneTwoAndThreeProcessesWriteTheModelOfOneProcess) {
  const fs::path dir = written_btf("mpi");
  const std::string fit = " fit " + (dir / "btf").string() +
                          " -M 40 --iterations 4 --seed 3 --objective likelihood -q -o ";
  ASSERT_EQ(
      shell(std::string(BTFGMM_CLI_PATH) + fit + (dir / "one.btfgmm").string() + " --threads 1",
            dir)
          .status,
      0);
  const std::string one = model_of_file(dir / "one.btfgmm");
  ASSERT_EQ(one.substr(0, 2), "gm");
  for (int np : {1, 2, 3}) {
    const fs::path out = dir / ("np" + std::to_string(np) + ".btfgmm");
    const fs::path log = dir / ("np" + std::to_string(np) + ".csv");
    const test::CliRun r =
        shell(under_mpirun(np) + fit + out.string() + " --threads 2 --log " + log.string(), dir);
    ASSERT_EQ(r.status, 0) << np << " processes: " << r.err;
    EXPECT_EQ(model_of_file(out), one) << np << " processes";
    // Process 0 alone writes the iteration log: a header and iterations 1 to 4, once each.
    std::ifstream in(log);
    std::string line, iterations;
    std::getline(in, line);
    EXPECT_EQ(line.substr(0, 10), "iteration,") << np << " processes";
    while (std::getline(in, line)) iterations += line.substr(0, line.find(',')) + " ";
    EXPECT_EQ(iterations, "1 2 3 4 ") << np << " processes";
  }
  // Each process holds whole lights: more processes than lights are refused, by name.
  const test::CliRun r = shell(under_mpirun(8) + fit + (dir / "np8.btfgmm").string(), dir);
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("8 processes for the 7 lights"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

// The default fit, for the prediction (EM, then the refinement with its validation and
// stopping rule), as 1, 2 and 3 processes of an MPI job writes the model of one process: every
// sum of the refinement is folded in light order, and so the decoded images are the same.
TEST(Scale, MpiJobsFitForThePredictionTheModelOfOneProcess) {
  const fs::path dir = written_btf("mpipred");
  // The default bounds (in steps): the same model on any number of processes at any load.
  const std::string fit =
      " fit " + (dir / "btf").string() + " -M 12 --iterations 4 --seed 3 -q -o ";
  ASSERT_EQ(
      shell(std::string(BTFGMM_CLI_PATH) + fit + (dir / "one.btfgmm").string() + " --threads 1",
            dir)
          .status,
      0);
  const std::string one = model_of_file(dir / "one.btfgmm");
  const BtfModel model = load_model(dir / "one.btfgmm");
  ASSERT_NE(recorded_objective(model.provenance), FitObjective::kLikelihood);
  const auto images = [](const BtfModel& m) {
    const Btf b = decode(m, m.lights, m.views, m.width, m.height);
    return std::vector<float>(b.data().begin(), b.data().end());
  };
  const std::vector<float> decoded = images(model);
  for (int np : {1, 2, 3}) {
    const fs::path out = dir / ("np" + std::to_string(np) + ".btfgmm");
    // The 3-process job tells its progress (process 0 prints it): the plan's timed passes are
    // joined by every process, told or not (a job whose process 0 alone timed them hung).
    std::string job = fit;
    if (np == 3) job.replace(job.find(" -q "), 4, " ");
    const test::CliRun r = shell(under_mpirun(np) + job + out.string() + " --threads 2", dir);
    ASSERT_EQ(r.status, 0) << np << " processes: " << r.err;
    if (np == 3) {
      EXPECT_NE(r.err.find("plan: EM on the "), std::string::npos) << r.err;
    }
    EXPECT_EQ(model_of_file(out), one) << np << " processes";
    const BtfModel m = load_model(out);
    EXPECT_EQ(images(m), decoded) << np << " processes";
  }
  fs::remove_all(dir);
}

// One process of a 2-process job, killed with SIGKILL mid-fit, ends the job; the checkpoint
// process 0 wrote is whole, and a 3-process job resumes from it to the model of an
// uninterrupted fit.
TEST(Scale, KilledProcessEndsTheJobAndThreeProcessesResumeToTheSameModel) {
  const fs::path dir = written_btf("mpikill");
  const fs::path ckpt = dir / "fit.ckpt", model = dir / "cut.btfgmm";
  const std::string settings = " -M 100 --iterations 40 --seed 4 --objective likelihood -q ";
  ASSERT_EQ(shell(std::string(BTFGMM_CLI_PATH) + " fit " + (dir / "btf").string() + settings +
                      "-o " + (dir / "full.btfgmm").string(),
                  dir)
                .status,
            0);
  const std::string full = model_of_file(dir / "full.btfgmm");
  const pid_t job = fork();
  if (job == 0) {
    const std::string cmd = under_mpirun(2) + " fit " + (dir / "btf").string() + settings + "-o " +
                            model.string() + " --checkpoint " + ckpt.string() + " 2> " +
                            (dir / "job.txt").string();
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Once the checkpoint holds 2 iterations, kill a process of the fit (not mpirun): one whose
  // command line names the checkpoint and starts with the command's path.
  bool killed = false;
  for (int i = 0; i < 30000 && !killed; ++i) {
    try {
      if (fs::exists(ckpt) && load_checkpoint(ckpt).state.result.iterations >= 2)
        killed = kill_fit_process(ckpt.string());
    } catch (const Error&) {
    }
    if (!killed) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  int status = 0;
  waitpid(job, &status, 0);
  ASSERT_TRUE(killed) << "the fit ended before a process could be killed";
  EXPECT_NE(WEXITSTATUS(status), 0);
  EXPECT_FALSE(fs::exists(model));
  const FitCheckpoint k = load_checkpoint(ckpt);  // whole: it reads
  EXPECT_GE(k.state.result.iterations, 2);
  EXPECT_LT(k.state.result.iterations, 40);
  // The launcher says which process died and how.
  std::ifstream said(dir / "job.txt");
  const std::string job_err((std::istreambuf_iterator<char>(said)),
                            std::istreambuf_iterator<char>());
  EXPECT_NE(job_err.find("signal 9"), std::string::npos) << job_err;
  const test::CliRun r =
      shell(under_mpirun(3) + " fit --resume " + ckpt.string() + " --objective likelihood -q", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(model_of_file(model), full);
  EXPECT_FALSE(fs::exists(ckpt));
  fs::remove_all(dir);
}
#else
TEST(Scale, MpiJobsOfOneTwoAndThreeProcessesWriteTheModelOfOneProcess) {
  GTEST_SKIP() << "built without MPI (BTFGMM_MPI, the Debian packages libopenmpi-dev openmpi-bin)";
}
#endif

}  // namespace
}  // namespace btfgmm
