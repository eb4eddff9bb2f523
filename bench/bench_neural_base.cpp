// bench_neural_base: the neural BTF with and without the mean BRDF as a base.
//
// Rainer et al. (2019) let the network predict the colour itself; the Gaussian mixture
// predicts around the mean BRDF (the paper's Eq. 11), which its file stores. For each
// generated tile and latent length L this fits the neural BTF twice with the same network and
// seed: to the tile (as `fit --method neural` does), and to the tile less its mean BRDF (each
// measured image's mean colour), whose decode then has the mean BRDF added back. It prints,
// per fit, the model file's bytes and, for the base, the bytes the mean BRDF adds as the
// mixture's compact file stores it (the file of a one-component mixture of the tile, which
// holds little else: an upper bound), the PSNR over every sample and over the held-out ones
// alone (validation_sample, the samples neither fit learnt from), and the fit's time.
//
//   bench_neural_base [--materials a,b,...] [--size S] [--directions SPEC]
//                     [--latents L1,L2,...] [--iterations EPOCHS] [--threads N]
//
// Defaults: knit, corduroy and leather, S = 16, ubo81 directions, L = 4, 8 and 16, the
// fit's default epochs. A quick check: bench_neural_base --size 6 --directions rings:0/1,30/4
// --latents 2 --iterations 2 --materials knit.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench_clock.hpp"
#include "btfgmm/btfgmm.hpp"
#include "btfgmm/model/refine.hpp"
#include "btfgmm/model/samples.hpp"

namespace {

struct Options {
  std::vector<std::string> materials = {"knit", "corduroy", "leather"};
  int size = 16, iterations = 0, threads = 0;
  std::string directions = "ubo81";
  std::vector<std::size_t> latents = {4, 8, 16};
};

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--materials")
      o.materials = split(value);
    else if (flag == "--size")
      o.size = std::atoi(value.c_str());
    else if (flag == "--directions")
      o.directions = value;
    else if (flag == "--iterations")
      o.iterations = std::atoi(value.c_str());
    else if (flag == "--threads")
      o.threads = std::atoi(value.c_str());
    else if (flag == "--latents") {
      o.latents.clear();
      for (const std::string& l : split(value)) o.latents.push_back(std::stoul(l));
    } else {
      std::fprintf(stderr, "bench_neural_base: unknown option %s\n", flag.c_str());
      std::exit(2);
    }
  }
  if (argc % 2 == 0) {
    std::fprintf(stderr, "bench_neural_base: option %s needs a value\n", argv[argc - 1]);
    std::exit(2);
  }
  return o;
}

// `tile` with `sign` times the mean BRDF added to every pixel of each image.
btfgmm::Btf with_base(btfgmm::Btf tile, const std::vector<float>& mean, float sign) {
  const std::size_t pixels = std::size_t(tile.width()) * std::size_t(tile.height());
  for (std::size_t j = 0; j < tile.image_count(); ++j)
    for (std::size_t p = 0; p < pixels; ++p)
      for (std::size_t c = 0; c < 3; ++c)
        tile.data()[(j * pixels + p) * 3 + c] += sign * mean[j * 3 + c];
  return tile;
}

struct Quality {
  double psnr_all = 0.0, psnr_held_out = 0.0;
};

double psnr(double squared, double count) {
  return 20.0 * std::log10(255.0 / std::sqrt(squared / count));
}

// The PSNR of `decoded` against `tile` over every sample and over the held-out ones.
Quality quality(const btfgmm::Btf& decoded, const btfgmm::Btf& tile) {
  const std::size_t pixels = std::size_t(tile.width()) * std::size_t(tile.height());
  const std::size_t pairs = tile.image_count();
  double all = 0.0, held = 0.0, held_count = 0.0;
  for (std::size_t j = 0; j < pairs; ++j)
    for (std::size_t p = 0; p < pixels; ++p) {
      double e = 0.0;
      for (std::size_t c = 0; c < 3; ++c) {
        const std::size_t i = (j * pixels + p) * 3 + c;
        e +=
            double(decoded.data()[i] - tile.data()[i]) * double(decoded.data()[i] - tile.data()[i]);
      }
      all += e;
      if (btfgmm::validation_sample(p, j, pairs)) {
        held += e;
        held_count += 3.0;
      }
    }
  return {.psnr_all = psnr(all, double(tile.data().size())),
          .psnr_held_out = psnr(held, std::max(held_count, 1.0))};
}

// The file of a one-component mixture of `tile` (its mean BRDF in the compact coding, one
// component, the frame and provenance).
std::size_t stored_mean_brdf_bytes(const btfgmm::Btf& tile) {
  btfgmm::FitOptions s;
  s.method = "gm";
  s.components = 1;
  s.iterations = 1;
  s.objective = "likelihood";
  const auto model = btfgmm::fit_and_record(btfgmm::find_method("gm"), tile, s, {});
  return btfgmm::representation_file_bytes(*model).size();
}

struct Fitted {
  std::size_t bytes = 0;
  Quality q;
  double seconds = 0.0;
};

// The neural BTF of size L fitted to `target`, decoded at its directions, `base` added back.
Fitted fit_and_measure(const btfgmm::Btf& tile, const btfgmm::Btf& target,
                       const std::vector<float>& base, std::size_t latent, const Options& o) {
  btfgmm::FitOptions s;
  s.method = "neural";
  s.components = latent;
  s.iterations = o.iterations;
  s.threads = o.threads;
  const double t0 = bench::now();
  const auto model = btfgmm::fit_and_record(btfgmm::find_method("neural"), target, s, {});
  Fitted f;
  f.seconds = bench::now() - t0;
  f.bytes = btfgmm::representation_file_bytes(*model).size();
  const btfgmm::Btf decoded =
      model->decode(tile.lights(), tile.views(), tile.width(), tile.height(), 0.0);
  f.q = quality(with_base(decoded, base, 1.0f), tile);
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  std::printf("neural BTF with and without the mean BRDF as a base: %d x %d tiles, %s directions\n",
              o.size, o.size, o.directions.c_str());
  std::printf("%-9s %4s %-5s %9s %10s %10s %10s %10s %8s\n", "material", "L", "base", "file B",
              "+ base B", "all B", "PSNR all", "held-out", "fit s");
  for (const std::string& material : o.materials) {
    btfgmm::GenerateConfig g;
    g.material = material;
    g.size = o.size;
    g.lights = g.views = btfgmm::DirectionSet::parse(o.directions);
    const btfgmm::Btf tile = btfgmm::generate(g);
    const std::vector<float> mean = btfgmm::mean_brdf(tile);  // light-major, as image_index
    const std::vector<float> none(mean.size(), 0.0f);
    const btfgmm::Btf residual = with_base(tile, mean, -1.0f);
    const std::size_t base_bytes = stored_mean_brdf_bytes(tile);
    for (const std::size_t latent : o.latents) {
      const Fitted plain = fit_and_measure(tile, tile, none, latent, o);
      const Fitted based = fit_and_measure(tile, residual, mean, latent, o);
      std::printf("%-9s %4zu %-5s %9zu %10d %10zu %10.2f %10.2f %8.1f\n", material.c_str(), latent,
                  "none", plain.bytes, 0, plain.bytes, plain.q.psnr_all, plain.q.psnr_held_out,
                  plain.seconds);
      std::printf("%-9s %4zu %-5s %9zu %10zu %10zu %10.2f %10.2f %8.1f\n", material.c_str(), latent,
                  "mean", based.bytes, base_bytes, based.bytes + base_bytes, based.q.psnr_all,
                  based.q.psnr_held_out, based.seconds);
      std::printf("%-9s %4zu base - none: %+.2f dB over all, %+.2f dB held out, %+zd bytes\n",
                  material.c_str(), latent, based.q.psnr_all - plain.q.psnr_all,
                  based.q.psnr_held_out - plain.q.psnr_held_out,
                  std::ptrdiff_t(based.bytes + base_bytes) - std::ptrdiff_t(plain.bytes));
      std::fflush(stdout);
    }
  }
  return 0;
}
