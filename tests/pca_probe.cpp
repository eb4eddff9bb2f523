// pca_probe: writes matrices and what btfgmm's PCAs make of them, for the independent check
// against numpy's SVD (tests/numpy_pca_check.py).
//
// Usage: pca_probe OUTDIR. Writes OUTDIR/cases.txt, one case a line:
//   error NAME C CENTRE ERROR DISCARDED FILE:ROWS:COLS [FILE:ROWS:COLS ...]
//     ERROR: the squared error of btfgmm's reconstruction with C components of every matrix
//     listed (each centred when CENTRE is 1); DISCARDED: what btfgmm's PCA says it discards.
//     numpy: both equal the sum over the matrices of their discarded squared singular values.
//   recon NAME C CENTRE FILE:ROWS:COLS RECON_FILE
//     RECON_FILE: btfgmm's reconstruction of the matrix, which numpy's rank-C reconstruction
//     must equal.
// Matrices are raw little-endian float32, row-major.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/methods/lpca.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/synth/generate.hpp"
#include "core/random.hpp"
#include "methods/lpca_fit.hpp"
#include "methods/pca.hpp"

namespace {

namespace fs = std::filesystem;

struct Matrix {
  std::vector<float> values;
  std::size_t rows = 0, cols = 0;
};

// A matrix of low rank plus noise, with an offset per column.
Matrix test_matrix(std::size_t rows, std::size_t cols, std::uint64_t seed) {
  btfgmm::detail::SplitMix64 rng(seed);
  Matrix m{.values = std::vector<float>(rows * cols), .rows = rows, .cols = cols};
  std::vector<double> u(rows * 6), v(6 * cols);
  for (double& x : u) x = rng.uniform(-1.0, 1.0);
  for (double& x : v) x = rng.uniform(-1.0, 1.0);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) {
      double s = double(j % 7) * 10.0 + rng.uniform(-3.0, 3.0);
      for (std::size_t k = 0; k < 6; ++k)
        s += 50.0 / double(k + 1) * u[i * 6 + k] * v[k * cols + j];
      m.values[i * cols + j] = float(s);
    }
  return m;
}

class Writer {
 public:
  explicit Writer(fs::path dir) : dir_(std::move(dir)), cases_(dir_ / "cases.txt") {}

  // The matrix's file spec FILE:ROWS:COLS.
  std::string put(const std::string& name, const std::vector<float>& v, std::size_t rows,
                  std::size_t cols) {
    const fs::path p = dir_ / (name + ".f32");
    std::ofstream(p, std::ios::binary)
        .write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * 4));
    return p.string() + ":" + std::to_string(rows) + ":" + std::to_string(cols);
  }
  void line(const std::string& text) { cases_ << text << "\n"; }

 private:
  fs::path dir_;
  std::ofstream cases_;
};

std::string number(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// The shared PCA on plain matrices: both shapes, centred or not, the randomized path too.
void core_cases(Writer& w) {
  int id = 0;
  for (const auto& [rows, cols] : {std::pair<std::size_t, std::size_t>{24, 50}, {50, 24}}) {
    const Matrix m = test_matrix(rows, cols, 100 + std::uint64_t(rows));
    for (bool centre : {true, false})
      for (std::size_t c : {2, 5}) {
        btfgmm::detail::PcaSettings s;
        s.centre = centre;
        const auto p = btfgmm::detail::principal_components(m.values, rows, cols, c, s);
        const auto r = btfgmm::detail::reconstruct(p);
        double e = 0.0;
        for (std::size_t i = 0; i < r.size(); ++i)
          e += (r[i] - double(m.values[i])) * (r[i] - double(m.values[i]));
        const std::string name = "core" + std::to_string(id++);
        w.line("error " + name + " " + std::to_string(c) + " " + (centre ? "1 " : "0 ") +
               number(e) + " " + number(p.discarded_energy) + " " +
               w.put(name, m.values, rows, cols));
      }
  }
  // The randomized SVD on a matrix it may take (its threshold lowered).
  const Matrix m = test_matrix(160, 130, 7);
  btfgmm::detail::PcaSettings s;
  s.randomized_above = 100;
  const auto p = btfgmm::detail::principal_components(m.values, 160, 130, 4, s);
  if (!p.randomized) throw btfgmm::Error(btfgmm::Error::Kind::kArgument, "not randomized");
  const auto r = btfgmm::detail::reconstruct(p);
  double e = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i)
    e += (r[i] - double(m.values[i])) * (r[i] - double(m.values[i]));
  w.line("error randomized 4 1 " + number(e) + " " + number(p.discarded_energy) + " " +
         w.put("randomized", m.values, 160, 130));
}

// A small generated tile: 8 x 8 knit, 5 lights, 6 views.
btfgmm::Btf small_tile() {
  btfgmm::GenerateConfig g;
  g.material = "knit";
  g.size = 8;
  g.seed = 3;
  g.lights = btfgmm::DirectionSet::rings({{0, 1}, {30, 4}});
  g.views = btfgmm::DirectionSet::rings({{0, 1}, {45, 5}});
  return btfgmm::generate(g);
}

// The squared error of a method's decode (f32 factors) against the tile.
double method_error(const btfgmm::Btf& tile, const std::string& method, std::size_t c,
                    std::size_t clusters = 0) {
  btfgmm::FitOptions s;
  s.components = c;
  s.clusters = clusters;
  s.precision = btfgmm::FactorEncoding::kF32;
  const auto r = btfgmm::find_method(method).fit(tile, s);
  const btfgmm::Btf d = r->decode(tile.lights(), tile.views(), tile.width(), tile.height(), 0.0);
  double e = 0.0;
  for (std::size_t i = 0; i < d.data().size(); ++i) {
    const double diff = double(d.data()[i]) - double(tile.data()[i]);
    e += diff * diff;
  }
  return e;
}

// PCA BTF: the images as rows (ni*nv x 3MN).
void pca_btf_cases(Writer& w, const btfgmm::Btf& tile) {
  const std::string images = w.put("images", {tile.data().begin(), tile.data().end()},
                                   tile.image_count(), tile.image_floats());
  for (std::size_t c : {3, 8}) {
    const auto p = btfgmm::detail::principal_components(tile.data(), tile.image_count(),
                                                        tile.image_floats(), c);
    w.line("error pca-btf-c" + std::to_string(c) + " " + std::to_string(c) + " 1 " +
           number(method_error(tile, "pca-btf", c)) + " " + number(p.discarded_energy) + " " +
           images);
  }
}

// PCA RF: one matrix per view, that view's light images as rows (ni x 3MN).
void pca_rf_cases(Writer& w, const btfgmm::Btf& tile) {
  const std::size_t ni = tile.lights().size(), d = tile.image_floats();
  std::string specs;
  std::vector<std::vector<float>> views;
  for (std::size_t v = 0; v < tile.views().size(); ++v) {
    std::vector<float> m;
    for (std::size_t l = 0; l < ni; ++l) m.insert(m.end(), tile.image(l, v), tile.image(l, v) + d);
    std::string name = "view";
    name += std::to_string(v);
    specs += ' ';
    specs += w.put(name, m, ni, d);
    views.push_back(std::move(m));
  }
  for (std::size_t c : {1, 2}) {
    double discarded = 0.0;
    for (const auto& m : views)
      discarded += btfgmm::detail::principal_components(m, ni, d, c).discarded_energy;
    w.line("error pca-rf-c" + std::to_string(c) + " " + std::to_string(c) + " 1 " +
           number(method_error(tile, "pca-rf", c)) + " " + number(discarded) + specs);
  }
}

// LPCA with one cluster: the PCA of the texel-BRDF matrix (MN x ni*nv*3), its error and its
// reconstruction.
void lpca_cases(Writer& w, const btfgmm::Btf& tile) {
  const std::size_t texels = std::size_t(tile.width() * tile.height()),
                    dims = tile.image_count() * 3;
  const std::vector<float> x = btfgmm::detail::texel_brdfs(tile);
  const std::string brdfs = w.put("texels", x, texels, dims);
  for (std::size_t c : {3, 8}) {
    const auto p = btfgmm::detail::principal_components(x, texels, dims, c);
    w.line("error lpca-k1-c" + std::to_string(c) + " " + std::to_string(c) + " 1 " +
           number(method_error(tile, "lpca", c, 1)) + " " + number(p.discarded_energy) + " " +
           brdfs);
  }
  btfgmm::FitOptions s;
  s.clusters = 1;
  s.components = 3;
  s.precision = btfgmm::FactorEncoding::kF32;
  const auto r = btfgmm::find_method("lpca").fit(tile, s);
  const btfgmm::Btf d = r->decode(tile.lights(), tile.views(), tile.width(), tile.height(), 0.0);
  std::vector<float> recon(texels * dims);
  for (std::size_t p = 0; p < tile.image_count(); ++p)
    for (std::size_t t = 0; t < texels; ++t)
      for (std::size_t ch = 0; ch < 3; ++ch)
        recon[t * dims + p * 3 + ch] = d.data()[p * tile.image_floats() + t * 3 + ch];
  const std::string spec = w.put("lpca-recon", recon, texels, dims);
  w.line("recon lpca-k1-c3 3 1 " + brdfs + " " + spec.substr(0, spec.find(':')));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: pca_probe OUTDIR\n");
    return 2;
  }
  try {
    Writer w(argv[1]);
    core_cases(w);
    const btfgmm::Btf tile = small_tile();
    pca_btf_cases(w, tile);
    pca_rf_cases(w, tile);
    lpca_cases(w, tile);
  } catch (const btfgmm::Error& e) {
    std::fprintf(stderr, "pca_probe: %s\n", e.what());
    return 1;
  }
  return 0;
}
