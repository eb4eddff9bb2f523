// The neural BTF fit's checkpoints (methods/neural_btf_checkpoint.hpp): the file, in the
// conventions of the mixture's (model/checkpoint.cpp: magic, version, fields, CRC-32), and the
// fit job that saves and resumes them.
#include "btfgmm/methods/neural_btf_checkpoint.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <utility>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/provenance.hpp"
#include "methods/neural_btf_internal.hpp"
#include "model/byte_io.hpp"

namespace btfgmm {
namespace {

constexpr std::uint8_t kMagic[8] = {0x89, 'B', 'T', 'F', 'N', 'C', 'K', '\n'};
constexpr std::uint32_t kVersion = 2;  // 2: the made tile's description (1: none)
constexpr const char* kWhat = "neural fit checkpoint";
constexpr const char* kFix = "start the fit again without `resume`";
// The precision of options that set none (the method's default file).
constexpr std::uint32_t kNoPrecision = 255;
// The most epochs a fit takes (the declaration of `iterations`) and steps an epoch (a tile's
// samples, 2^32 at most, in minibatches of at least 128).
constexpr std::int32_t kMostEpochs = 100000;
constexpr std::uint64_t kMostSteps = (std::uint64_t(1) << 32) / 128;

void put_floats(detail::ByteWriter& w, const std::vector<float>& v) {
  w.put<std::uint64_t>(v.size());
  for (const float x : v) w.put<float>(x);
}

std::vector<float> get_floats(detail::ByteReader& r, const char* field) {
  const auto n = r.get<std::uint64_t>(field);
  if (n > r.remaining() / sizeof(float))
    r.fail(fmt::format("field '{}' claims {} values", field, n));
  std::vector<float> v(n);
  for (float& x : v) {
    x = r.get<float>(field);
    if (!std::isfinite(x)) r.fail(fmt::format("field '{}' holds {}", field, x));
  }
  return v;
}

void put_options(detail::ByteWriter& w, const FitOptions& o) {
  w.put<std::uint64_t>(o.components);
  w.put<std::uint64_t>(o.width);
  w.put<std::uint64_t>(o.depth);
  w.put<std::int32_t>(o.iterations);
  w.put<std::uint64_t>(o.seed);
  w.put<std::uint32_t>(o.precision ? std::uint32_t(*o.precision) : kNoPrecision);
}

// The options as saved, each within the range its declaration takes (a value a fit would
// refuse is a damaged file).
FitOptions get_options(detail::ByteReader& r) {
  FitOptions o;
  o.method = "neural";
  o.components = r.get<std::uint64_t>("latent values");
  o.width = r.get<std::uint64_t>("width");
  o.depth = r.get<std::uint64_t>("depth");
  o.iterations = r.get<std::int32_t>("epochs");
  o.seed = r.get<std::uint64_t>("seed");
  const auto precision = r.get<std::uint32_t>("precision");
  if (precision != kNoPrecision) {
    if (precision > std::uint32_t(FactorEncoding::kCompact)) r.fail("unknown precision");
    o.precision = FactorEncoding(precision);
  }
  const MethodInfo& neural = find_method("neural");
  for (const std::string_view field : {"components", "width", "depth", "iterations"})
    if (const auto v = parameter_value(o, *method_parameter(neural, field))) try {
        check_parameter_value(*method_parameter(neural, field), *v);
      } catch (const Error& e) {
        r.fail(e.what());
      }
  return o;
}

void put_state(detail::ByteWriter& w, const NeuralFitState& s) {
  w.put<std::int32_t>(s.epoch);
  w.put<std::uint64_t>(s.steps_done);
  w.put<std::uint8_t>(s.validation_due ? 1 : 0);
  put_floats(w, s.theta);
  put_floats(w, s.first_moment);
  put_floats(w, s.second_moment);
  w.put<std::int32_t>(s.adam_steps);
  put_floats(w, s.best_theta);
  w.put<double>(s.best_rmse);
  w.put<double>(s.rule_best);
  w.put<double>(s.rule_reference);
  w.put<double>(s.rate_scale);
  w.put<std::int32_t>(s.since_gain);
  w.put<std::int32_t>(s.plateaus);
}

NeuralFitState get_state(detail::ByteReader& r) {
  NeuralFitState s;
  s.epoch = r.get<std::int32_t>("epoch");
  s.steps_done = r.get<std::uint64_t>("steps done");
  const auto due = r.get<std::uint8_t>("validation due");
  if (due > 1) r.fail("the held-out check's flag is neither 0 nor 1");
  s.validation_due = due == 1;
  s.theta = get_floats(r, "parameters");
  s.first_moment = get_floats(r, "first moments");
  s.second_moment = get_floats(r, "second moments");
  s.adam_steps = r.get<std::int32_t>("Adam steps");
  s.best_theta = get_floats(r, "best parameters");
  s.best_rmse = r.get<double>("best held-out RMSE");
  s.rule_best = r.get<double>("rule's best");
  s.rule_reference = r.get<double>("rule's reference");
  s.rate_scale = r.get<double>("rate scale");
  s.since_gain = r.get<std::int32_t>("validations since a gain");
  s.plateaus = r.get<std::int32_t>("plateaus");
  const std::size_t n = s.theta.size();
  if (s.first_moment.size() != n || s.second_moment.size() != n || s.best_theta.size() != n)
    r.fail("the parameters, moments and best parameters differ in count");
  // The best error is infinite before the first validation; the rule's reference until a gain.
  if (std::isnan(s.best_rmse) || std::isnan(s.rule_best) || std::isnan(s.rule_reference) ||
      !(s.rate_scale > 0.0 && s.rate_scale <= 1.0) || s.since_gain < 0 || s.plateaus < 0)
    r.fail("the stopping rule's state is out of range");
  if (s.epoch < 0 || s.epoch > kMostEpochs || s.steps_done > kMostSteps || s.adam_steps < 0 ||
      (s.validation_due && s.steps_done == 0))
    r.fail("the fit's place (epoch, step, Adam's steps) is out of range");
  return s;
}

// The network's parameters and the latents of the options' shape (their defaults where unset)
// on `tile`; 0 for a shape past the limits a fit takes.
std::size_t parameters_on(const Tile& tile, const FitOptions& o) {
  const NeuralShape shape{.latent = o.components ? o.components : kNeuralDefaultLatent,
                          .width = o.width ? o.width : kNeuralDefaultWidth,
                          .depth = o.depth ? o.depth : kNeuralDefaultDepth};
  if (shape.latent > detail::kMaxLatent || shape.width > detail::kMaxWidth ||
      shape.depth > detail::kMaxDepth)
    return 0;
  return detail::parameter_count(detail::network_shape(shape)) +
         std::size_t(tile.width) * std::size_t(tile.height) * shape.latent;
}

Tile get_tile(detail::ByteReader& r) {
  Tile t;
  t.x = r.get<std::int32_t>("tile x");
  t.y = r.get<std::int32_t>("tile y");
  t.width = r.get<std::int32_t>("tile width");
  t.height = r.get<std::int32_t>("tile height");
  if (t.x < 0 || t.y < 0 || t.width <= 0 || t.height <= 0 || t.width > 65536 || t.height > 65536)
    r.fail("the tile is out of range");
  return t;
}

// A resume goes on with the data the checkpoint's fit saw.
void check_same_data(const NeuralCheckpoint& k, const std::string& path, const Btf& tile) {
  if (btf_fingerprint(tile) != k.data_fingerprint)
    throw Error(Error::Kind::kArgument,
                fmt::format("the data in '{}' is not what checkpoint '{}' was fitted to (the "
                            "tile's content, size or directions differ); go on with the "
                            "original data or fit again",
                            k.input, path));
}

}  // namespace

bool is_neural_checkpoint(std::span<const std::uint8_t> bytes) {
  return bytes.size() >= 8 && std::memcmp(bytes.data(), kMagic, 8) == 0;
}

bool is_neural_checkpoint_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint8_t head[8] = {};
  return in.read(reinterpret_cast<char*>(head), 8) && is_neural_checkpoint(head);
}

void save_neural_checkpoint(const NeuralCheckpoint& c, const std::filesystem::path& path) {
  detail::ByteWriter w;
  w.bytes.assign(kMagic, kMagic + 8);
  w.put<std::uint32_t>(kVersion);
  w.text(c.input);
  w.text(c.output);
  w.put<std::int32_t>(c.tile.x);
  w.put<std::int32_t>(c.tile.y);
  w.put<std::int32_t>(c.tile.width);
  w.put<std::int32_t>(c.tile.height);
  w.text(c.made_from);
  put_options(w, c.options);
  w.put<std::uint64_t>(c.data_fingerprint);
  w.put<double>(c.seconds);
  w.put<std::uint32_t>(c.runs);
  put_state(w, c.state);
  detail::append_crc32(w);
  write_file_atomically(path, w.bytes, kWhat);
}

NeuralCheckpoint read_neural_checkpoint(std::span<const std::uint8_t> bytes,
                                        const std::string& name) {
  if (bytes.size() < 16 || !is_neural_checkpoint(bytes))
    throw Error(Error::Kind::kFormat,
                fmt::format("'{}' is not a neural fit's checkpoint (what a fit of {} neural "
                            "writes with the option {}); {}",
                            name, option_name("method"), option_name("checkpoint"), kFix));
  if (!detail::crc32_holds(bytes))
    throw Error(Error::Kind::kFormat,
                fmt::format("{} '{}' is truncated or corrupted (checksum mismatch); {}", kWhat,
                            name, kFix));
  detail::ByteReader r(bytes.subspan(8, bytes.size() - 12), kWhat, name, kFix);
  const auto version = r.get<std::uint32_t>("version");
  if (version != kVersion && version != 1)
    throw Error(Error::Kind::kFormat,
                fmt::format("{} '{}' has version {}, written by {} btfgmm (this btfgmm reads "
                            "versions 1 to {}); resume it with that btfgmm, or {}",
                            kWhat, name, version, version < kVersion ? "an older" : "a newer",
                            kVersion, kFix));
  NeuralCheckpoint c;
  c.input = r.text("input");
  c.output = r.text("output");
  c.tile = get_tile(r);
  if (version >= 2) c.made_from = r.text("made tile");
  c.options = get_options(r);
  c.data_fingerprint = r.get<std::uint64_t>("data fingerprint");
  c.seconds = r.get<double>("seconds");
  c.runs = r.get<std::uint32_t>("runs");
  if (!(c.seconds >= 0.0 && c.seconds < 1e12) || c.runs == 0)
    r.fail("the time or runs so far are out of range");
  c.state = get_state(r);
  if (const std::size_t n = parameters_on(c.tile, c.options); c.state.theta.size() != n)
    r.fail(
        fmt::format("the state holds {} parameters where the network and latents of its "
                    "options on its tile hold {}",
                    c.state.theta.size(), n));
  if (r.remaining() != 0) r.fail(fmt::format("{} bytes left over", r.remaining()));
  return c;
}

NeuralCheckpoint load_neural_checkpoint(const std::filesystem::path& path) {
  return read_neural_checkpoint(read_whole_file(path, kWhat), path.string());
}

std::unique_ptr<Representation> fit_neural_job(const NeuralFitJob& job,
                                               std::shared_ptr<const BtfSource> source,
                                               const FitProgress& progress) {
  const auto t0 = Clock::now();
  FitOptions s = job.resume ? job.resume->options : job.options;
  s.threads = job.options.threads;
  s.progress = progress.progress;
  s.stop = progress.stop;
  const std::string& input = job.resume ? job.resume->input : job.input;
  if (!source) source = std::make_shared<const BtfSource>(BtfSource::open(input));
  const BtfInfo& info = source->info();
  const Tile tile = (job.resume ? job.resume->tile : job.tile).or_whole(info.width, info.height);
  const Btf btf = source->load(tile);
  if (job.resume) check_same_data(*job.resume, job.checkpoint, btf);
  if (progress.started)
    progress.started(FitTile{.lights = btf.lights(),
                             .views = btf.views(),
                             .origin = btf.origin(),
                             .format = btf.format()});
  NeuralCheckpoint k{.input = input,
                     .output = job.resume ? job.resume->output : job.output,
                     .tile = tile,
                     .options = s,
                     .data_fingerprint = btf_fingerprint(btf),
                     .runs = job.resume ? job.resume->runs + 1 : 1,
                     .state = {},
                     .made_from = btf.made_from()};
  const double before = job.resume ? job.resume->seconds : 0.0;
  NeuralCheckpointing checkpointing{.every_epochs = job.every_epochs,
                                    .save = {},
                                    .resume = job.resume ? &job.resume->state : nullptr};
  if (!job.checkpoint.empty())
    checkpointing.save = [&](const NeuralFitState& state) {
      k.seconds = before + seconds_since(t0);
      k.state = state;
      save_neural_checkpoint(k, job.checkpoint);
    };
  // The method's row with this fit in place of its own: recorded as any fit (fit_and_record).
  MethodInfo neural = find_method("neural");
  neural.fit = [&](const Btf& t, const FitOptions& o) {
    return fit_neural_btf(t, o, checkpointing);
  };
  std::unique_ptr<Representation> r =
      fit_and_record(neural, btf, s, fingerprint_of(btf, {input, info.width, info.height}));
  Provenance p = r->provenance();
  p.fit.seconds = before + seconds_since(t0);
  p.fit.runs = k.runs;
  r->set_provenance(std::move(p));
  return r;
}

}  // namespace btfgmm
