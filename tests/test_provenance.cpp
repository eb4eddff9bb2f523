// Provenance (model/provenance.hpp, docs/FORMAT.md): the data a model was fitted to and the
// fit's log, in every method's file; checked against data; older files read without it; a
// fit resumed with more iterations, and a finished one continued.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>

#include "btfgmm/btfgmm.hpp"
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/provenance.hpp"
#include "test_util.hpp"

namespace btfgmm {
namespace {

namespace fs = std::filesystem;
using test::error_of;

Btf small_tile(const std::string& material) {
  GenerateConfig g;
  g.material = material;
  g.size = 8;
  g.lights = DirectionSet::parse("rings:0/1,30/4,60/6");
  g.views = DirectionSet::parse("rings:0/1,45/5");
  return generate(g);
}

// A model of two components with a provenance of every kind of field.
BtfModel model_with_provenance() {
  BtfModel m;
  m.lights = DirectionSet({{0, 0}, {30, 90}});
  m.views = DirectionSet({{0, 0}});
  m.width = m.height = 4;
  m.origin = {.x = 2, .y = 1, .width = 4, .height = 4};
  m.mixture.resize(2);
  m.mixture.weight = {0.5, 0.5};
  for (auto& mu : m.mixture.mean) mu.fill(0.5);
  for (auto& v : m.mixture.var) v.fill(1.0);
  m.mean_brdf.assign(2 * 1 * 3, 10.0f);
  m.settings.components = 2;
  m.settings.iterations = 2;
  Provenance& p = m.provenance;
  p.recorded = true;
  p.data = {{"corduroy32/", 32, 32}, 0x0123456789abcdefull};
  p.fit.settings = {{"method", "gm"}, {"components", "2"}, {"seed", "7"}};
  p.fit.seconds = 1.5;
  p.fit.runs = 2;
  p.fit.iterations = {{-12.5, 0.25, 2}, {-11.0, 0.5, 2}};
  return m;
}

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> b) {
  const auto crc = std::uint32_t(crc32(0L, b.data(), uInt(b.size() - 4)));
  std::memcpy(b.data() + b.size() - 4, &crc, 4);
  return b;
}

TEST(Provenance, TheContentHashIsFnv1aOfTheValuesBytes) {
  Btf one(DirectionSet({{0, 0}}), DirectionSet({{0, 0}}), 1, 1, SampleFormat::kLdr8);
  one.data()[0] = 1.0f;
  one.data()[1] = 2.0f;
  one.data()[2] = 3.0f;
  // FNV-1a 64 of 00 00 80 3f 00 00 00 40 00 00 40 40, computed apart (Python).
  EXPECT_EQ(tile_content_hash(one), 0x1de40d89811fe258ull);
  EXPECT_EQ(hash_text(tile_content_hash(one)), "1de40d89811fe258");
  Btf other = one;
  other.data()[2] = 3.5f;
  EXPECT_NE(tile_content_hash(other), tile_content_hash(one));
}

TEST(Provenance, RoundTripsThroughTheModelFile) {
  const BtfModel m = model_with_provenance();
  const auto bytes = serialize_model(m);
  EXPECT_EQ(bytes[8], kModelFormatVersion);
  const BtfModel back = deserialize_model(bytes, "p.btfgmm");
  const Provenance& p = back.provenance;
  ASSERT_TRUE(p.recorded);
  EXPECT_EQ(p.data.source.name, "corduroy32/");
  EXPECT_EQ(p.data.source.image_width, 32);
  EXPECT_EQ(p.data.content_hash, 0x0123456789abcdefull);
  EXPECT_EQ(p.fit.settings, m.provenance.fit.settings);
  EXPECT_EQ(p.fit.seconds, 0.0);  // no time is written: the file is the same at any load
  EXPECT_EQ(p.fit.runs, 2u);
  ASSERT_EQ(p.fit.iterations.size(), 2u);
  EXPECT_EQ(p.fit.iterations[1].log_likelihood, -11.0);
  EXPECT_EQ(p.fit.iterations[1].seconds, 0.0);
  EXPECT_EQ(serialize_model(back), bytes);
  // Through the registry, as any method: the same provenance, the same bytes.
  const auto r = read_representation(bytes, "p.btfgmm");
  EXPECT_EQ(r->provenance().data.source.name, "corduroy32/");
  EXPECT_EQ(representation_file_bytes(*r), bytes);
  // Without one, an empty section: 4 bytes, read as none recorded.
  BtfModel none = m;
  none.provenance = {};
  const auto plain = serialize_model(none);
  EXPECT_FALSE(deserialize_model(plain, "n.btfgmm").provenance.recorded);
  EXPECT_GT(bytes.size(), plain.size());
}

TEST(Provenance, EveryTruncationAndCorruptionIsRefused) {
  const auto bytes = serialize_model(model_with_provenance());
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + std::ptrdiff_t(n));
    EXPECT_THROW(deserialize_model(cut, "cut.btfgmm"), Error) << "prefix " << n;
  }
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    auto bad = bytes;
    bad[i] ^= 0x40;
    EXPECT_THROW(deserialize_model(bad, "bad.btfgmm"), Error) << "byte " << i;
  }
}

// After the header (24 bytes) and the tag (u32 2, "gm"), the provenance's size (u32) at byte
// 30, then the provenance: source (u32 11, "corduroy32/") from 34, image width and height
// (u32) at 49, the content hash (u64) at 57, fit seconds (f64) at 65, runs (u32) at 73,
// settings from 77.
TEST(Provenance, MalformedFieldsAreRefusedByName) {
  const auto good = serialize_model(model_with_provenance());
  auto refused = [&](std::size_t at, const void* v, std::size_t n) {
    auto b = good;
    std::memcpy(b.data() + at, v, n);
    return error_of([&] { deserialize_model(with_crc(b), "m.btfgmm"); });
  };
  const char bell = 7;
  EXPECT_NE(refused(40, &bell, 1).find("'source' holds a control character"), std::string::npos);
  const std::uint32_t huge = 0xFFFFFFFF, zero = 0;
  EXPECT_NE(refused(30, &huge, 4).find("provenance of 4294967295 bytes"), std::string::npos);
  EXPECT_NE(refused(34, &huge, 4).find("provenance field 'source' of 4294967295 bytes"),
            std::string::npos);
  EXPECT_NE(refused(49, &zero, 4).find("image size 0x32"), std::string::npos);
  const double negative = -1.0, nan = std::nan("");
  EXPECT_NE(refused(65, &negative, 8).find("'fit seconds' is -1"), std::string::npos);
  EXPECT_NE(refused(65, &nan, 8).find("'fit seconds'"), std::string::npos);
  EXPECT_NE(refused(73, &zero, 4).find("0 runs"), std::string::npos);
  // Sizes that do not match the fields: one byte short (the last field cut), one byte long
  // (a byte of the payload left over in the provenance).
  const std::uint32_t size = std::uint32_t(good[30] | good[31] << 8);
  const std::uint32_t shorter = size - 1, longer = size + 1;
  EXPECT_NE(refused(30, &shorter, 4).find("2 iterations logged do not fit the provenance"),
            std::string::npos);
  EXPECT_NE(refused(30, &longer, 4).find("1 bytes after its last field"), std::string::npos);
}

// Files written before provenance: version 1 (the mixture), version 2 (a mixture here, every
// other method in test_methods.cpp's golden files): read with none recorded, to the same
// values.
TEST(Provenance, OlderFilesReadWithNoneRecorded) {
  const fs::path data = BTFGMM_TEST_DATA;
  EXPECT_FALSE(load_model(data / "golden_v1.btfgmm").provenance.recorded);
  const auto gm = load_representation(data / "golden_v2_gm.btfgmm");
  EXPECT_FALSE(gm->provenance().recorded);
  const Query q[] = {{.x = 1.5, .y = 2.25, .light = {30, 90}, .view = {45, 72}},
                     {.x = 0, .y = 0, .light = {0, 0}, .view = {0, 0}}};
  // As `btfgmm eval` of the btfgmm that wrote it printed them.
  const float want[6] = {144.5882f, 80.7728f, 58.2584f, 143.0921f, 83.0417f, 63.0924f};
  float rgb[6];
  gm->predict(q, rgb);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(rgb[i], want[i], 1e-4) << i;
  for (const char* method : {"pca-btf", "pca-rf", "lpca", "ptm-rf", "plm-rf"}) {
    const auto m = load_representation(data / (std::string("golden_v2_") + method + ".btfgmm"));
    EXPECT_FALSE(m->provenance().recorded) << method;
    // Written again: the current version, an empty provenance.
    const auto again = representation_file_bytes(*m);
    EXPECT_EQ(again[8], kModelFormatVersion);
    EXPECT_FALSE(read_representation(again, "again")->provenance().recorded) << method;
  }
}

TEST(Provenance, DataIsCheckedAgainstTheRecord) {
  const Btf corduroy = small_tile("corduroy"), knit = small_tile("knit");
  FitOptions s;
  s.components = 2;
  const DataFingerprint fp = fingerprint_of(corduroy, {"corduroy8/", 8, 8});
  const auto model = fit_and_record(find_method("pca-btf"), corduroy, s, fp);
  EXPECT_EQ(check_fitted_data(*model, "c.btfgmm", corduroy, {"anywhere/", 8, 8}).match,
            DataMatch::kSame);
  const DataCheck other = check_fitted_data(*model, "c.btfgmm", knit, {"knit8/", 8, 8});
  EXPECT_EQ(other.match, DataMatch::kOtherContent);
  for (const std::string& needle :
       {std::string("'knit8/' is not the data 'c.btfgmm' was fitted to"),
        std::string("partial match"), std::string("'corduroy8/'"),
        hash_text(tile_content_hash(corduroy)), hash_text(tile_content_hash(knit))})
    EXPECT_NE(other.message.find(needle), std::string::npos) << needle << ": " << other.message;
  GenerateConfig g;
  g.size = 8;
  g.lights = DirectionSet::parse("rings:0/1,30/4");
  g.views = DirectionSet::parse("rings:0/1,45/5");
  const DataCheck dirs = check_fitted_data(*model, "c.btfgmm", generate(g), {"few/", 8, 8});
  EXPECT_EQ(dirs.match, DataMatch::kOtherDirections);
  EXPECT_NE(dirs.message.find("11 lights x 6 views"), std::string::npos) << dirs.message;
  auto unrecorded = read_representation(representation_file_bytes(*model), "c.btfgmm");
  unrecorded->set_provenance({});
  EXPECT_EQ(check_fitted_data(*unrecorded, "c.btfgmm", knit, {}).match, DataMatch::kNotRecorded);
}

TEST(Provenance, EveryMethodsFileRecordsItsDataAndFit) {
  const Btf tile = small_tile("corduroy");
  const DataFingerprint fp = fingerprint_of(tile, {"corduroy8/", 8, 8});
  for (const MethodInfo& method : all_methods()) {
    FitOptions s;
    const bool gm = method.name == "gm", fixed = method.name == "ptm-rf" || method.name == "plm-rf";
    const bool subspaces =
        method.name == "3d-car" || method.name == "2d-car" || method.name == "gmrf";
    s.components = gm ? 3 : fixed || subspaces ? 0 : 2;
    s.clusters = method.name == "lpca" || subspaces ? 2 : 0;
    s.iterations = gm || method.name == "plm-rf" ? 3 : 0;
    const auto fitted = fit_and_record(method, tile, s, fp);
    const auto back = read_representation(representation_file_bytes(*fitted), "m");
    const Provenance& p = back->provenance();
    ASSERT_TRUE(p.recorded) << method.name;
    EXPECT_EQ(p.data.source.name, "corduroy8/");
    EXPECT_EQ(p.data.content_hash, tile_content_hash(tile));
    EXPECT_EQ(p.fit.settings.front(),
              std::make_pair(std::string("method"), std::string(method.name)));
    EXPECT_EQ(p.fit.settings.back().first, "size");
    // The fit's time is the run's (in memory), not the file's: the same file at any load.
    EXPECT_GT(fitted->provenance().fit.seconds, 0.0) << method.name;
    EXPECT_EQ(p.fit.seconds, 0.0) << method.name;
    EXPECT_EQ(representation_file_bytes(*fit_and_record(method, tile, s, fp)),
              representation_file_bytes(*fitted))
        << method.name;
    EXPECT_EQ(p.fit.iterations.size(), method.name == "gm" ? 3u : 0u) << method.name;
  }
}

// Two BTFs on disk for run_fit (made once for all the tests), and a folder of each test's own.
// A file's bytes.
std::string file_bytes(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class ProvenanceFit : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = fs::temp_directory_path() / ("btfgmm_prov_data_" + std::to_string(::getpid()));
    fs::remove_all(data_);
    write_utia(small_tile("corduroy"), data_ / "btf");
    write_utia(small_tile("knit"), data_ / "knit");
  }
  static void TearDownTestSuite() { fs::remove_all(data_); }
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("btfgmm_prov_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  FitRequest request(int iterations, const std::string& out) const {
    FitRequest r;
    r.input = (data_ / "btf").string();
    r.tile = {.x = 1, .y = 2, .width = 6, .height = 5};
    r.config.components = 8;
    r.config.seed = 4;
    r.config.em.max_iterations = iterations;
    r.output = (dir_ / out).string();
    return r;
  }
  static inline fs::path data_;
  fs::path dir_;
};

TEST_F(ProvenanceFit, AFitRecordsItsDataAndItsLog) {
  const FitOutcome f = run_fit(request(3, "m.btfgmm"));
  const BtfModel m = load_model(dir_ / "m.btfgmm");
  const Provenance& p = m.provenance;
  ASSERT_TRUE(p.recorded);
  // Neither threads nor processes are settings: the model is the same with any number.
  for (const auto& [name, value] : p.fit.settings) {
    EXPECT_NE(name, "threads");
    EXPECT_NE(name, "processes");
  }
  EXPECT_EQ(p.data.source.name, (data_ / "btf").string());
  EXPECT_EQ(p.data.source.image_width, 8);
  const Btf tile = BtfSource::open(data_ / "btf").load({.x = 1, .y = 2, .width = 6, .height = 5});
  EXPECT_EQ(p.data.content_hash, tile_content_hash(tile));
  EXPECT_EQ(p.fit.runs, 1u);
  ASSERT_EQ(p.fit.iterations.size(), 3u);
  // The log is EM's: L of each iteration as fit_em returns it.
  FitConfig c;
  c.components = 8;
  c.seed = 4;
  c.em.max_iterations = 3;
  FitState state;
  (void)fit_model(tile, c, {}, nullptr, {}, &state);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(p.fit.iterations[i].log_likelihood, state.result.log_likelihood[i]);
  EXPECT_EQ(p.fit.iterations[2].components, 8u);
  // The file records no time (the same file at any load); the fit in memory has its times.
  EXPECT_EQ(p.fit.iterations[2].seconds, 0.0);
  EXPECT_EQ(p.fit.seconds, 0.0);
  EXPECT_GT(f.model.provenance.fit.seconds, 0.0);
  EXPECT_GE(f.model.provenance.fit.iterations[2].seconds,
            f.model.provenance.fit.iterations[0].seconds);
  EXPECT_NE(std::find(p.fit.settings.begin(), p.fit.settings.end(),
                      std::make_pair(std::string("seed"), std::string("4"))),
            p.fit.settings.end());
  EXPECT_EQ(f.model.provenance.data.content_hash, p.data.content_hash);
}

// A fit for the prediction records its refinement (steps and the RMSE before and after) in
// its settings; a stop during the refinement (none during EM) ends it early, and the model
// is still written, complete, with the steps it took on record.
TEST_F(ProvenanceFit, AFitForThePredictionRecordsItsRefinement) {
  FitRequest r = request(3, "m.btfgmm");
  r.config.objective = FitObjective::kPrediction;
  const FitOutcome f = run_fit(r);
  ASSERT_TRUE(f.refinement);
  EXPECT_FALSE(f.refinement->stopped);
  EXPECT_GT(f.refinement->steps, 0);  // until the validation error stopped falling
  EXPECT_FALSE(f.refinement->timed_out);
  EXPECT_LT(f.refinement->error_final, f.refinement->error_em);
  const BtfModel written = load_model(dir_ / "m.btfgmm");
  const auto& settings = written.provenance.fit.settings;
  ASSERT_EQ(settings.back().first, "refinement");
  EXPECT_EQ(
      settings.back().second.rfind(std::to_string(f.refinement->steps) + " Adam steps in ", 0), 0u)
      << settings.back().second;
  EXPECT_NE(settings.back().second.find("; validation RMSE "), std::string::npos);
  EXPECT_NE(settings.back().second.find(", training RMSE "), std::string::npos);

  std::atomic<bool> stop{false};
  r.output = (dir_ / "stopped.btfgmm").string();
  r.config.em.stop = &stop;
  FitObserver observer;
  observer.refinement = [&stop](const GradientProgress& p) {
    if (p.step == 4) stop.store(true);
  };
  const FitOutcome s = run_fit(r, observer);
  EXPECT_FALSE(s.interrupted);
  ASSERT_TRUE(s.refinement);
  EXPECT_TRUE(s.refinement->stopped);
  EXPECT_EQ(s.refinement->steps, 4);
  EXPECT_LE(s.refinement->error_final, s.refinement->error_colour);
  const BtfModel m = load_model(r.output);
  EXPECT_EQ(m.provenance.fit.iterations.size(), 3u);
  // EM's final state is kept beside the model: resumed, the refinement runs again, whole,
  // and ends where the uninterrupted fit's did.
  ASSERT_EQ(s.checkpoint, r.output + ".ckpt");
  ASSERT_TRUE(fs::exists(s.checkpoint));
  FitRequest resumed = resume_request(s.checkpoint);
  resumed.config.objective = FitObjective::kPrediction;  // the command's, as fit --resume sets it
  const FitOutcome again = run_fit(resumed);
  ASSERT_TRUE(again.refinement);
  EXPECT_FALSE(again.refinement->stopped);
  EXPECT_EQ(again.refinement->steps, f.refinement->steps);
  EXPECT_EQ(again.model.mixture.mean, f.model.mixture.mean);
  EXPECT_EQ(again.model.mixture.var, f.model.mixture.var);
  EXPECT_FALSE(fs::exists(s.checkpoint));                          // gone with the model written
  EXPECT_EQ(file_bytes(r.output), file_bytes(dir_ / "m.btfgmm"));  // the very same file
  EXPECT_NE(m.provenance.fit.settings.back().second.find(" (stopped); validation RMSE "),
            std::string::npos)
      << m.provenance.fit.settings.back().second;
  // Steps asked for (fit --refine-steps) instead of those the fit affords.
  r.config.em.stop = nullptr;
  r.config.refinement_steps = 17;
  r.output = (dir_ / "longer.btfgmm").string();
  const FitOutcome longer = run_fit(r);
  ASSERT_TRUE(longer.refinement);
  EXPECT_EQ(longer.refinement->steps, 17);
  EXPECT_LE(longer.refinement->error_final, longer.refinement->error_colour);
  const BtfModel longer_model = load_model(r.output);
  EXPECT_EQ(longer_model.provenance.fit.settings.back().second.rfind("17 Adam steps in ", 0), 0u);
  // The steps asked for are a setting of their own, which a continuation keeps.
  EXPECT_NE(std::find(longer_model.provenance.fit.settings.begin(),
                      longer_model.provenance.fit.settings.end(),
                      std::make_pair(std::string("refine steps"), std::string("17"))),
            longer_model.provenance.fit.settings.end());
  EXPECT_EQ(
      continue_request(r.output, "", 5, (dir_ / "on.btfgmm").string()).config.refinement_steps, 17);
  // EM alone records no refinement.
  EXPECT_FALSE(run_fit(request(3, "em.btfgmm")).refinement);
}

// Before EM a fit states its plan: the iterations left (those of the run it resumes aside),
// one iteration's time, timed on a few lights, and the refinement's bound (none for EM
// alone). Asking for the plan does not change the model.
TEST_F(ProvenanceFit, AFitStatesItsPlanBeforeEm) {
  FitRequest r = request(6, "planned.btfgmm");
  r.config.objective = FitObjective::kPrediction;
  r.config.refinement_seconds = 12.5;
  std::optional<FitPlan> plan;
  bool planned_before_em = false;
  FitObserver o;
  o.planned = [&](const FitPlan& p) { plan = p; };
  o.iteration = [&](const EmProgress& p) {
    if (p.iteration == 1) planned_before_em = plan.has_value();
  };
  run_fit(r, o);
  ASSERT_TRUE(plan);
  EXPECT_TRUE(planned_before_em);
  EXPECT_EQ(plan->components, 8u);
  EXPECT_EQ(plan->iterations, 6);
  EXPECT_GT(plan->em_iteration_seconds, 0.0);
  EXPECT_LT(plan->em_iteration_seconds, 30.0);  // 8 components on 6 x 5 pixels
  EXPECT_EQ(plan->refinement_seconds, 12.5);
  EXPECT_EQ(plan->refinement_max_steps, 0);  // the bound in time replaces the one in steps
  EXPECT_GT(plan->refinement.step_seconds, 0.0);
  EXPECT_GT(plan->refinement.seconds, plan->refinement.colour_refit_seconds);
  EXPECT_LE(plan->refinement.seconds, 12.5 + plan->refinement.colour_refit_seconds);

  std::atomic<bool> stop{false};
  FitRequest first = request(6, "em.btfgmm");
  first.config.em.stop = &stop;
  first.checkpoint = (dir_ / "em.ckpt").string();
  FitObserver stopper;
  stopper.iteration = [&](const EmProgress& p) { stop = p.iteration >= 2; };
  ASSERT_TRUE(run_fit(first, stopper).interrupted);
  FitRequest rest = resume_request(dir_ / "em.ckpt");
  plan.reset();
  run_fit(rest, o);
  ASSERT_TRUE(plan);
  EXPECT_EQ(plan->iterations, 4);
  EXPECT_FALSE(plan->refines);  // EM alone

  // Interrupted during EM and resumed, planned or not: the file of a fit never interrupted.
  run_fit(request(6, "unplanned.btfgmm"));
  EXPECT_EQ(file_bytes(dir_ / "em.btfgmm"), file_bytes(dir_ / "unplanned.btfgmm"));
}

// The default fit (EM, then the refinement bounded in steps) writes the same file, byte for
// byte, with one thread and with two, and states its refinement's bound in steps before EM.
TEST_F(ProvenanceFit, TheDefaultFitWritesTheSameFileWithAnyThreadCount) {
  std::optional<FitPlan> plan;
  FitObserver o;
  o.planned = [&](const FitPlan& p) { plan = p; };
  std::optional<RefinementEstimate> before;
  o.refinement_planned = [&](const RefinementEstimate& e) { before = e; };
  int refits = 0;  // colour refits summed to the end, as their progress tells
  o.refinement = [&](const GradientProgress& p) { refits += p.colour_refit && p.fraction == 1.0; };
  FitRequest one = request(3, "one.btfgmm");
  one.config.objective = FitObjective::kPrediction;
  one.config.em.threads = 1;
  const FitOutcome a = run_fit(one, o);
  ASSERT_TRUE(plan && before && a.refinement);
  EXPECT_EQ(plan->refinement_max_steps, kDefaultRefineSteps);
  // The step bound, or the epochs' where the tile has few minibatches (this one: 1 an epoch).
  EXPECT_EQ(before->steps,
            std::min<long long>(kDefaultRefineSteps, kMaxRefineEpochs * before->steps_per_epoch));
  EXPECT_GT(before->steps_per_epoch, 0u);
  EXPECT_LE(a.refinement->steps, kDefaultRefineSteps);
  EXPECT_EQ(refits, 2);  // before the steps and after them
  FitRequest two = one;
  two.output = (dir_ / "two.btfgmm").string();
  two.config.em.threads = 2;
  run_fit(two);
  EXPECT_EQ(file_bytes(dir_ / "one.btfgmm"), file_bytes(dir_ / "two.btfgmm"));
  // Bounded in time, the provenance says the model depends on the machine.
  FitRequest timed = one;
  timed.output = (dir_ / "timed.btfgmm").string();
  timed.config.refinement_seconds = 60;
  run_fit(timed);
  const auto& settings = load_model(timed.output).provenance.fit.settings;
  EXPECT_NE(std::find(settings.begin(), settings.end(),
                      std::make_pair(std::string("reproducible"), std::string(kBoundInTime))),
            settings.end());
}

// An interrupted fit resumed with more iterations ends where one fit of that many does: the
// same parameters, bit for bit, and the same log of L.
TEST_F(ProvenanceFit, AResumeGoesOnToTheIterationsAskedFor) {
  run_fit(request(10, "whole.btfgmm"));
  std::atomic<bool> stop{false};
  FitRequest first = request(6, "part.btfgmm");
  first.config.em.stop = &stop;
  first.checkpoint = (dir_ / "part.ckpt").string();
  FitObserver o;
  o.iteration = [&](const EmProgress& p) { stop = p.iteration >= 3; };
  ASSERT_TRUE(run_fit(first, o).interrupted);
  FitRequest rest = resume_request(dir_ / "part.ckpt");
  EXPECT_EQ(rest.resume->checkpoint.runs, 1u);
  rest.config.em.max_iterations = 10;
  run_fit(rest);
  const BtfModel whole = load_model(dir_ / "whole.btfgmm");
  const BtfModel resumed = load_model(dir_ / "part.btfgmm");
  EXPECT_EQ(mixture_payload(resumed), mixture_payload(whole));
  EXPECT_EQ(resumed.settings.max_iterations, 10u);
  EXPECT_EQ(resumed.provenance.fit.runs, 1u);  // one fit, interrupted and resumed
  EXPECT_EQ(file_bytes(dir_ / "part.btfgmm"), file_bytes(dir_ / "whole.btfgmm"));
  ASSERT_EQ(resumed.provenance.fit.iterations.size(), 10u);
  for (int i = 0; i < 10; ++i)
    EXPECT_EQ(resumed.provenance.fit.iterations[i].log_likelihood,
              whole.provenance.fit.iterations[i].log_likelihood);
  // Fewer iterations than already run are refused.
  stop = false;
  ASSERT_TRUE(run_fit(first, o).interrupted);
  FitRequest fewer = resume_request(dir_ / "part.ckpt");
  fewer.config.em.max_iterations = 2;
  EXPECT_NE(error_of([&] { run_fit(fewer); }).find("has already run 3 iterations"),
            std::string::npos);
}

// A finished fit of 6 iterations continued to 10 against one fit of 10. The continued fit
// starts from the parameters as stored (32-bit floats; deviations, not variances), not from
// EM's double-precision state, so it is not bit for bit: L agrees to 1e-7 relative and every
// stored parameter to 1e-4 relative (measured: 2.4e-9 and 3e-7 on this tile).
TEST_F(ProvenanceFit, AFinishedFitContinuedEqualsOneLongerFit) {
  run_fit(request(10, "ten.btfgmm"));
  run_fit(request(6, "six.btfgmm"));
  run_fit(continue_request(dir_ / "six.btfgmm", "", 10, (dir_ / "more.btfgmm").string()));
  const BtfModel ten = load_model(dir_ / "ten.btfgmm");
  const BtfModel more = load_model(dir_ / "more.btfgmm");
  EXPECT_EQ(more.settings.iterations, 10u);
  EXPECT_EQ(more.provenance.fit.runs, 2u);
  ASSERT_EQ(more.provenance.fit.iterations.size(), 10u);
  double worst_l = 0.0, worst_p = 0.0;
  for (int i = 0; i < 10; ++i) {
    const double a = ten.provenance.fit.iterations[i].log_likelihood;
    const double b = more.provenance.fit.iterations[i].log_likelihood;
    if (i < 6) {
      EXPECT_EQ(a, b) << i;  // the first six are the same fit's
    }
    worst_l = std::max(worst_l, std::abs(a - b) / std::abs(a));
  }
  worst_l = std::max(worst_l, std::abs(ten.settings.log_likelihood - more.settings.log_likelihood) /
                                  std::abs(ten.settings.log_likelihood));
  ASSERT_EQ(more.mixture.size(), ten.mixture.size());
  for (std::size_t k = 0; k < ten.mixture.size(); ++k) {
    auto rel = [](double a, double b) { return std::abs(a - b) / std::max(std::abs(a), 1.0); };
    worst_p = std::max(worst_p, rel(ten.mixture.weight[k], more.mixture.weight[k]));
    for (int n = 0; n < kVariables; ++n) {
      worst_p = std::max(worst_p, rel(ten.mixture.mean[k][n], more.mixture.mean[k][n]));
      worst_p = std::max(worst_p, rel(ten.mixture.var[k][n], more.mixture.var[k][n]));
    }
  }
  std::printf("continued against one fit: L %.2g, parameters %.2g relative\n", worst_l, worst_p);
  EXPECT_LT(worst_l, 1e-7);
  EXPECT_LT(worst_p, 1e-4);
  EXPECT_EQ(more.mean_brdf, ten.mean_brdf);
}

TEST_F(ProvenanceFit, AContinuationRefusesWhatCannotGoOn) {
  run_fit(request(4, "four.btfgmm"));
  const std::string out = (dir_ / "more.btfgmm").string();
  FitRequest fewer = continue_request(dir_ / "four.btfgmm", "", 3, out);
  EXPECT_NE(error_of([&] { run_fit(fewer); }).find("has already run 4 iterations"),
            std::string::npos);
  FitRequest knit = continue_request(dir_ / "four.btfgmm", (data_ / "knit").string(), 6, out);
  const std::string msg = error_of([&] { run_fit(knit); });
  EXPECT_NE(msg.find("is not what model"), std::string::npos) << msg;
  EXPECT_NE(msg.find((data_ / "btf").string()), std::string::npos) << msg;
  const fs::path data = BTFGMM_TEST_DATA;
  EXPECT_NE(error_of([&] {
              continue_request(data / "golden_v2_gm.btfgmm", "", 6, out);
            }).find("records no provenance"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              continue_request(data / "golden_v2_pca-btf.btfgmm", "", 6, out);
            }).find("holds a 'pca-btf' model"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(out));
}

TEST(Provenance, CheckpointsKeepTheLogAndRefuseTheOldVersion) {
  FitCheckpoint k;
  k.input = "btf";
  k.output = "m.btfgmm";
  k.runs = 3;
  k.state.mixture.resize(1);
  k.state.mixture.weight = {1.0};
  k.state.result.iterations = 2;
  k.state.result.log_likelihood = {-3.0, -2.0};
  k.state.result.seconds = {0.5, 1.25};
  k.state.result.components = {4, 3};
  const fs::path path = fs::temp_directory_path() / ("btfgmm_prov_" + std::to_string(::getpid()));
  save_checkpoint(k, path);
  const FitCheckpoint back = load_checkpoint(path);
  EXPECT_EQ(back.runs, 3u);
  EXPECT_EQ(back.state.result.seconds, k.state.result.seconds);
  EXPECT_EQ(back.state.result.components, k.state.result.components);
  // Version 1 (before the log): refused, naming it.
  std::ifstream in(path, std::ios::binary);
  std::vector<std::uint8_t> b((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
  in.close();
  b[8] = 1;
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(with_crc(b).data()), std::streamsize(b.size()));
  const std::string msg = error_of([&] { load_checkpoint(path); });
  EXPECT_NE(msg.find("version 1, written by an older btfgmm"), std::string::npos) << msg;
  fs::remove(path);
}

}  // namespace
}  // namespace btfgmm
