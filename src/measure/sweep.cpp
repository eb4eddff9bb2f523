// The rate-distortion sweep and its Pareto front; see sweep.hpp.
#include "btfgmm/measure/sweep.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <set>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/prediction_device.hpp"
#include "btfgmm/methods/registry.hpp"

namespace btfgmm {

namespace {

// One setting to fit: its method and settings, as the request makes them.
struct Setting {
  const MethodInfo* method = nullptr;
  FitOptions settings;
  std::string text;  // settings_text
};

// The methods the request names, checked: known, each once; every method when none is named.
std::vector<const MethodInfo*> chosen_methods(const SweepRequest& r) {
  std::vector<const MethodInfo*> out;
  if (r.methods.empty()) {
    for (const MethodInfo& m : all_methods()) out.push_back(&m);
    return out;
  }
  for (const std::string& name : r.methods) {
    const MethodInfo& m = find_method(name);
    if (std::find(out.begin(), out.end(), &m) != out.end())
      throw Error(
          Error::Kind::kArgument,
          fmt::format("sweep: the method '{}' is named twice; name each method once", name));
    out.push_back(&m);
  }
  return out;
}

bool given(const SweepRequest& r, std::string_view field) {
  return std::find(r.given.begin(), r.given.end(), field) != r.given.end();
}

// The refinement's bounds of a request: taken by a method swept.
void check_refinement_bounds(const SweepRequest& r, std::span<const MethodInfo* const> methods) {
  const std::string_view field = given(r, "refine_epochs")    ? "refine_epochs"
                                 : given(r, "refine_seconds") ? "refine_seconds"
                                                              : "";
  if (field.empty()) return;
  if (std::none_of(methods.begin(), methods.end(),
                   [field](const MethodInfo* m) { return method_parameter(*m, field) != nullptr; }))
    throw Error(Error::Kind::kArgument,
                fmt::format("sweep: {} bound the refinement of the Gaussian mixture (gm), which "
                            "is not swept; add gm to the methods or leave them out",
                            option_name(field)));
}

// Every setting of every chosen method, with the request's options that it takes.
std::vector<Setting> sweep_settings(const ModelFrame& frame, const SweepRequest& r) {
  const std::vector<const MethodInfo*> methods = chosen_methods(r);
  check_refinement_bounds(r, methods);
  for (const auto& [name, ladder] : r.ladders) {
    const MethodInfo& m = find_method(name);
    if (std::find(methods.begin(), methods.end(), &m) == methods.end())
      throw Error(Error::Kind::kArgument,
                  fmt::format("sweep: settings are given for '{}', a method not swept; add it "
                              "to the methods or leave its settings out",
                              name));
  }
  std::vector<Setting> out;
  for (const MethodInfo* m : methods) {
    const auto own = r.ladders.find(m->name);
    const std::vector<FitOptions> ladder = own != r.ladders.end() ? own->second : m->ladder(frame);
    for (FitOptions s : ladder) {
      s.method = m->name;
      for (const std::string_view f : r.given)
        if (const FitParameter* p = method_parameter(*m, f)) copy_parameter(r.options, s, *p);
      if (!s.precision) s.precision = default_file_encoding(*m);
      s.progress = nullptr;
      s.stop = r.stop;
      out.push_back({m, s, settings_text(s)});
    }
  }
  return out;
}

// "<method>-<size>" from the model's size text ("M = 30" -> "gm-M30", "k = 8, c = 4" ->
// "lpca-k8-c4"), made unique among `taken` with "-2", "-3", ...
std::string model_name(const Representation& r, std::set<std::string>& taken) {
  std::string size;
  for (char ch : r.size_text()) {
    if (std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '_')
      size += ch;
    else if ((ch == ',' || ch == ';') && !size.empty() && size.back() != '-')
      size += '-';
  }
  std::string name = std::string(r.method()) + (size.empty() ? "" : "-" + size);
  for (int k = 2; taken.count(name); ++k)
    name = fmt::format("{}-{}{}", r.method(), size.empty() ? "" : size + "-", k);
  taken.insert(name);
  return name;
}

// Reports events to the request's progress callback, with the setting and the elapsed time.
class Reporter {
 public:
  Reporter(const SweepRequest& r, std::size_t count) : r_(r), count_(count) {}
  std::size_t done = 0;  // settings fitted or skipped
  void operator()(SweepProgress::Event e, const Setting& s, std::size_t index,
                  SweepProgress extra = {}) const {
    if (!r_.progress) return;
    extra.event = e;
    extra.method = s.method->name;
    extra.index = index;
    extra.count = count_;
    extra.settings = s.text;
    extra.elapsed_seconds = seconds_since(start_);
    extra.done = done;
    extra.remaining_seconds =
        done ? extra.elapsed_seconds / double(done) * double(count_ - done) : std::nan("");
    r_.progress(extra);
  }

 private:
  const SweepRequest& r_;
  std::size_t count_;
  Clock::time_point start_ = Clock::now();
};

// Fits one setting, counts its file bytes, writes the file if asked, and measures the model
// read back from those bytes.
ModelComparison fit_and_measure(const Btf& tile, const DataFingerprint& data, const SweepRequest& r,
                                Setting& s, std::size_t index, const Reporter& report,
                                std::set<std::string>& names) {
  if (r.progress)
    s.settings.progress = [&](double fraction, std::string_view stage) {
      SweepProgress p;
      p.fraction = fraction;
      p.stage = stage;
      report(SweepProgress::Event::kFit, s, index, p);
    };
  const auto t0 = Clock::now();
  std::shared_ptr<const Representation> model = fit_and_record(*s.method, tile, s.settings, data);
  const double fit_seconds = seconds_since(t0);
  s.settings.progress = nullptr;
  // A fit stopped by the flag that kept its best model met (the neural BTF's) is not done.
  if (r.stop && r.stop->load())
    throw Error(Error::Kind::kArgument, fmt::format("{} {}: stopped", s.method->name, s.text));
  report(SweepProgress::Event::kMeasure, s, index);
  const std::vector<std::uint8_t> bytes = representation_file_bytes(*model);
  const std::string name = model_name(*model, names);
  if (!r.model_folder.empty())
    write_file_atomically(r.model_folder / (name + ".btfgmm"), bytes, "model file");
  // Measured as its file holds it (factors in the file's precision), as `compare` would.
  std::unique_ptr<Representation> read = read_representation(bytes, name);
  compute_where_fitted(*read, s.settings);
  ModelComparison c = compare_model(tile, std::move(read), name, bytes.size(), r.compare);
  c.fit_seconds = fit_seconds;
  return c;
}

void create_model_folder(const std::filesystem::path& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec || !std::filesystem::is_directory(folder))
    throw Error(Error::Kind::kIo,
                fmt::format("sweep: cannot create the model folder '{}': {}; check the path and "
                            "its permissions",
                            folder.string(), ec ? ec.message() : "not a folder"));
}

}  // namespace

std::string settings_text(const FitOptions& s) {
  std::string t;
  auto add = [&](const char* what, std::size_t v) {
    if (v) t += fmt::format("{}{} {}", t.empty() ? "" : ", ", what, v);
  };
  add("clusters", s.clusters);
  add("components", s.components);
  add("degree", s.degree);
  add("width", s.width);
  add("depth", s.depth);
  if (s.iterations) t += fmt::format("{}iterations {}", t.empty() ? "" : ", ", s.iterations);
  add("refine epochs", std::size_t(std::max(s.refine_epochs, 0)));
  if (s.refine_seconds)
    t += fmt::format("{}refine seconds {:g}", t.empty() ? "" : ", ", s.refine_seconds);
  return t.empty() ? std::string("the method's defaults") : t;
}

SweepOutcome run_sweep(const Btf& tile, const SweepRequest& request) {
  std::vector<Setting> settings = sweep_settings(ModelFrame::of(tile), request);
  if (!request.model_folder.empty()) create_model_folder(request.model_folder);
  SweepOutcome out;
  out.total = settings.size();
  Reporter report(request, settings.size());
  std::set<std::string> names;
  const DataFingerprint data = fingerprint_of(tile, request.source);
  for (std::size_t k = 0; k < settings.size(); ++k) {
    if (request.stop && request.stop->load()) {
      out.stopped = true;
      break;
    }
    Setting& s = settings[k];
    report(SweepProgress::Event::kStart, s, k);
    try {
      out.models.push_back(fit_and_measure(tile, data, request, s, k, report, names));
      out.settings.push_back(s.text);
    } catch (const Error& e) {
      // A fit stopped by the flag ends the sweep; any other refused setting is recorded.
      if (request.stop && request.stop->load()) {
        out.stopped = true;
        break;
      }
      if (e.kind() != Error::Kind::kArgument) throw;
      out.skipped.push_back({std::string(s.method->name), s.text, e.what()});
      ++report.done;
      SweepProgress p;
      p.message = out.skipped.back().message;
      report(SweepProgress::Event::kSkipped, s, k, p);
      continue;
    }
    ++report.done;
    SweepProgress p;
    p.result = &out.models.back();
    report(SweepProgress::Event::kDone, s, k, p);
  }
  out.pareto = pareto_front(out.models);
  if (given(request, "iterations"))
    for (const MethodInfo* m : chosen_methods(request))
      if (!method_parameter(*m, "iterations")) out.not_iterated.emplace_back(m->name);
  return out;
}

std::vector<bool> pareto_front(std::span<const std::array<double, 2>> ratio_psnr) {
  const std::size_t n = ratio_psnr.size();
  std::vector<bool> front(n, false);
  auto valid = [](const std::array<double, 2>& p) {
    return !std::isnan(p[0]) && !std::isnan(p[1]);
  };
  for (std::size_t i = 0; i < n; ++i) {
    const auto& a = ratio_psnr[i];
    if (!valid(a)) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < n && !dominated; ++j) {
      const auto& b = ratio_psnr[j];
      dominated =
          j != i && valid(b) && b[0] >= a[0] && b[1] >= a[1] && (b[0] > a[0] || b[1] > a[1]);
    }
    front[i] = !dominated;
  }
  return front;
}

std::vector<bool> pareto_front(std::span<const ModelComparison> models) {
  std::vector<std::array<double, 2>> points;
  for (const ModelComparison& c : models)
    points.push_back({c.file_bytes > 0 && !c.model->synthesises()
                          ? c.model->file_ratio(c.file_bytes)
                          : std::nan(""),
                      c.quality.psnr_db});
  return pareto_front(points);
}

}  // namespace btfgmm
