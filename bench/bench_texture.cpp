// bench_texture: how much the probabilistic texture models (3d-car, 2d-car, gmrf) look like
// their data, by the statistics of measure/texture_statistics.hpp.
//
// For each material, a generated S x S BTF (`btfgmm generate --material M --size S --seed 5`
// with the direction sets given), each method fitted with the defaults (or --clusters,
// --levels), and N images spread over the (light, view) pairs synthesised at T x T pixels
// (twice the tile by default) and compared with their data images: per image, each channel's
// mean difference and deviation ratio, the largest autocorrelation difference at lags 1-4 in
// x and y, the luminance histogram's distance, the largest row/column mean jump against the
// data's (a streak) and the shares of saturated values. Prints a markdown row per material
// and method (the worst image of each figure, the means of the others) and, with --pictures
// DIR, writes DIR/texture-MATERIAL.png: the middle one of the images, its data tiled 2 x 2
// beside each method's synthesis; with --above DIR2, below DIR2's picture of the same name
// (a before/after pair).
//
//   bench_texture [--size S] [--synthesis T] [--lights SPEC] [--views SPEC] [--images N]
//                 [--materials a,b] [--methods a,b] [--clusters C] [--levels K]
//                 [--pictures DIR] [--above DIR2] [--models DIR]
//
// --models DIR reads DIR/MATERIAL-METHOD.btfgmm instead of fitting (models fitted by another
// btfgmm to the same generated data, e.g. an older one: `btfgmm generate ... -o knit` and
// `btfgmm fit knit --method 3d-car -o DIR/knit-3d-car.btfgmm`).
//
// Defaults: S = 64, T = 128, lights spiral:25, views spiral:9, N = 12, knit, corduroy and
// leather, all three methods. A second table gives the autocorrelation at each lag, data /
// model.
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "btfgmm/io/image.hpp"
#include "btfgmm/measure/texture_statistics.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/synth/generate.hpp"

namespace {

using namespace btfgmm;

struct Options {
  int size = 64, synthesis = 128, images = 12, levels = 0;
  std::size_t clusters = 0;
  std::string lights = "spiral:25", views = "spiral:9", pictures, models, above;
  std::vector<std::string> materials = {"knit", "corduroy", "leather"};
  std::vector<std::string> methods = {"3d-car", "2d-car", "gmrf"};
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t at = 0;
  for (std::size_t comma; (comma = s.find(',', at)) != std::string::npos; at = comma + 1)
    out.push_back(s.substr(at, comma - at));
  out.push_back(s.substr(at));
  return out;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--size")
      o.size = std::atoi(v.c_str());
    else if (k == "--synthesis")
      o.synthesis = std::atoi(v.c_str());
    else if (k == "--images")
      o.images = std::atoi(v.c_str());
    else if (k == "--levels")
      o.levels = std::atoi(v.c_str());
    else if (k == "--clusters")
      o.clusters = std::size_t(std::atoi(v.c_str()));
    else if (k == "--lights")
      o.lights = v;
    else if (k == "--views")
      o.views = v;
    else if (k == "--pictures")
      o.pictures = v;
    else if (k == "--above")
      o.above = v;
    else if (k == "--models")
      o.models = v;
    else if (k == "--materials")
      o.materials = split(v);
    else if (k == "--methods")
      o.methods = split(v);
    else {
      fmt::print(stderr, "bench_texture: unknown option {}\n", k);
      std::exit(2);
    }
  }
  return o;
}

// One image: its data, its synthesis, their comparison.
struct Pair {
  std::vector<float> data, model;
  TextureImageStatistics data_stats, model_stats;
  TextureImageComparison c;
};

std::vector<std::size_t> chosen_images(const Btf& data, int n) {
  std::vector<std::size_t> out;
  const std::size_t count = data.image_count();
  for (int k = 0; k < n; ++k) out.push_back((std::size_t(k) * count + count / 2) / std::size_t(n));
  return out;
}

std::vector<Pair> measure(const Btf& data, const Representation& model, const Options& o) {
  std::vector<Pair> out;
  const std::size_t nv = data.views().size();
  for (std::size_t i : chosen_images(data, o.images)) {
    Pair p;
    const float* d = data.data().data() + i * data.image_floats();
    p.data.assign(d, d + data.image_floats());
    const DirectionSet light({data.lights()[i / nv]}), view({data.views()[i % nv]});
    const Btf s = model.decode(light, view, o.synthesis, o.synthesis, 0);
    p.model.assign(s.data().begin(), s.data().end());
    p.data_stats = texture_image_statistics(p.data, data.width(), data.height());
    p.model_stats = texture_image_statistics(p.model, o.synthesis, o.synthesis);
    p.c = compare_texture_images(p.data_stats, p.model_stats);
    out.push_back(std::move(p));
  }
  return out;
}

void print_row(const std::string& material, const std::string& method, const Representation& m,
               const std::vector<Pair>& pairs) {
  std::vector<TextureImageComparison> c;
  std::vector<TextureImageStatistics> d, s;
  for (const Pair& p : pairs)
    c.push_back(p.c), d.push_back(p.data_stats), s.push_back(p.model_stats);
  const TextureStatistics t = summarise_texture(c, d, s);
  fmt::print(
      "| {}, {} | {} | {:.2f} / {:.2f} | {:.2f} to {:.2f} | {:.3f} / {:.3f} | {:.3f} | "
      "{:.2f} | {:.2f} / {:.2f} |\n",
      material, method, m.parameter_count(), t.mean_difference, t.worst_mean_difference,
      t.lowest_deviation_ratio, t.highest_deviation_ratio, t.autocorrelation_difference,
      t.worst_autocorrelation_difference, t.histogram_distance, t.worst_streak_ratio,
      100 * t.saturated_data, 100 * t.saturated_model);
  std::fflush(stdout);
}

// The luminance autocorrelation at lags 1-4 in x and in y, data / model, each the mean over
// the images: a row of the second table (the structure the first's difference summarises).
std::string lag_row(const std::string& material, const std::string& method,
                    const std::vector<Pair>& pairs) {
  std::string row = fmt::format("| {}, {} |", material, method);
  for (int axis = 0; axis < 2; ++axis)
    for (int k = 0; k < kTextureLags; ++k) {
      double d = 0, m = 0;
      for (const Pair& p : pairs) {
        d +=
            (axis ? p.data_stats.rho_y : p.data_stats.rho_x)[std::size_t(k)] / double(pairs.size());
        m += (axis ? p.model_stats.rho_y : p.model_stats.rho_x)[std::size_t(k)] /
             double(pairs.size());
      }
      row += fmt::format(" {:.2f} / {:.2f} |", d, m);
    }
  return row + "\n";
}

// One row: the middle chosen image's data tiled 2 x 2, then each method's synthesis, 4 pixels
// apart; below the row of the same name in `above_dir` where one is given (a before/after
// pair).
void write_picture_of(const std::filesystem::path& path, const Btf& data,
                      const std::vector<std::vector<Pair>>& methods, const Options& o) {
  constexpr int kGap = 4;
  const int t = o.synthesis, cols = 1 + int(methods.size());
  const int w = cols * t + (cols - 1) * kGap;
  std::vector<float> img(std::size_t(w) * std::size_t(t) * 3, 255.0f);
  const auto put = [&](int ox, const std::vector<float>& src, int sw, int sh) {
    for (int y = 0; y < t; ++y)
      for (int x = 0; x < t; ++x)
        for (int c = 0; c < 3; ++c)
          img[(std::size_t(y) * std::size_t(w) + std::size_t(ox + x)) * 3 + std::size_t(c)] =
              src[(std::size_t(y % sh) * std::size_t(sw) + std::size_t(x % sw)) * 3 +
                  std::size_t(c)];
  };
  const std::size_t k = methods[0].size() / 2;
  put(0, methods[0][k].data, data.width(), data.height());
  for (std::size_t m = 0; m < methods.size(); ++m)
    put(int(m + 1) * (t + kGap), methods[m][k].model, t, t);
  int h = t;
  if (!o.above.empty()) {
    const Image above = read_image(std::filesystem::path(o.above) / path.filename());
    if (above.width == w) {
      std::vector<float> both(above.rgb);
      both.resize(both.size() + std::size_t(w) * kGap * 3, 255.0f);
      both.insert(both.end(), img.begin(), img.end());
      img = std::move(both);
      h += above.height + kGap;
    }
  }
  write_png(path, w, h, img);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  fmt::print("S = {}, synthesis {} x {}, lights {}, views {}, {} images, clusters {}, levels {}\n",
             o.size, o.synthesis, o.synthesis, o.lights, o.views, o.images,
             o.clusters ? std::to_string(o.clusters) : "default",
             o.levels ? std::to_string(o.levels) : "default");
  fmt::print(
      "| material, method | values | mean difference, mean / worst | deviation ratio | "
      "autocorrelation difference, mean / worst | histogram distance | streak ratio, "
      "worst | saturated % data / model |\n|---|---|---|---|---|---|---|---|\n");
  std::string lag_rows;
  for (const std::string& material : o.materials) {
    GenerateConfig g;
    g.material = material;
    g.size = o.size;
    g.seed = 5;
    g.lights = DirectionSet::parse(o.lights);
    g.views = DirectionSet::parse(o.views);
    const Btf data = generate(g);
    std::vector<std::vector<Pair>> all;
    for (const std::string& method : o.methods) {
      FitOptions s;
      s.clusters = o.clusters;
      s.levels = o.levels;
      const auto model = o.models.empty()
                             ? find_method(method).fit(data, s)
                             : load_representation(std::filesystem::path(o.models) /
                                                   (material + "-" + method + ".btfgmm"));
      all.push_back(measure(data, *model, o));
      print_row(material, method, *model, all.back());
      lag_rows += lag_row(material, method, all.back());
    }
    if (!o.pictures.empty())
      write_picture_of(std::filesystem::path(o.pictures) / ("texture-" + material + ".png"), data,
                       all, o);
  }
  fmt::print(
      "\n| material, method | rho_x(1) data / model | rho_x(2) | rho_x(3) | rho_x(4) | rho_y(1) | "
      "rho_y(2) | rho_y(3) | rho_y(4) |\n|---|---|---|---|---|---|---|---|---|\n{}",
      lag_rows);
  return 0;
}
