// The neural BTF (Rainer, Jakob, Ghosh & Weyrich 2019, "Neural BTF Compression and
// Interpolation", Eurographics): a latent vector of L values per texel and one multilayer
// perceptron shared by the tile, which maps a texel's latent and a light and a view direction
// to the texel's RGB (methods/neural_network.hpp). The latents and the network are fitted
// together by Adam, as the paper's decoder is; the paper's encoder, which predicts the latents
// of a new material without a fit, is not part of it. The model evaluates any pixel (the
// latents interpolated bilinearly between texels; the tile repeats) at any pair of directions
// on the hemisphere, measured or not.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "btfgmm/methods/representation.hpp"

namespace btfgmm {

// The network's size: L latent values per texel, `depth` hidden layers of `width` units.
struct NeuralShape {
  std::size_t latent = 0, width = 0, depth = 0;
};

class NeuralBtf final : public Representation {
 public:
  // latents: pixels x L (row-major: a texel's latent together), stored as `encoding` stores
  // them; parameters: the network's flat vector (methods/neural_network.hpp), stored as 16-bit
  // floats; `scale`: the data value of a network output of 1.
  NeuralBtf(ModelFrame frame, NeuralShape shape, FactorEncoding encoding, float scale,
            std::vector<float> latents, std::vector<float> parameters);

  const NeuralShape& shape() const { return shape_; }
  float scale() const { return scale_; }
  std::span<const float> latents() const { return latents_; }
  std::span<const float> network_parameters() const { return parameters_; }

  std::string_view method() const override;
  const ModelFrame& frame() const override { return frame_; }
  // "L = 8, 2 x 64".
  std::string size_text() const override;
  double size_order() const override { return double(parameter_count()); }
  // The paper's count: the latents (W*H*L) and the network's weights and biases.
  std::uint64_t parameter_count() const override;
  void predict(std::span<const Query> queries, std::span<float> rgb) const override;
  Btf decode(const DirectionSet& lights, const DirectionSet& views, int width, int height,
             double tolerance) const override;
  std::vector<std::uint8_t> payload() const override;
  FactorEncoding encoding() const override { return encoding_; }
  std::vector<std::pair<std::string, std::string>> details() const override;
  // predict() and decode() by the network on `device` (null: the CPU), within float rounding
  // of the CPU's (docs/GPU.md, "Decoding on the GPU").
  bool compute_on(std::shared_ptr<ComputeDevice> device) override;

 private:
  ModelFrame frame_;
  NeuralShape shape_;
  FactorEncoding encoding_;
  float scale_;
  std::vector<float> latents_, parameters_;
  std::shared_ptr<ComputeDevice> device_;  // null: the CPU
};

// The default shape of a fit (`components` L, `width`, `depth`) and its most epochs
// (`iterations`): 30, fewer where they would take more than about 18,000 Adam steps (a 25 x 25
// tile of 81 x 81 directions: 18 epochs of 952 steps, 4 minutes on 2 cores), but at least 6
// where those take at most about 40,000 steps (a 64 x 64 tile: 6 epochs of 6,233 steps; a
// texel's latent learns only from its own samples, once an epoch), and at least one.
constexpr std::size_t kNeuralDefaultLatent = 8;
constexpr std::size_t kNeuralDefaultWidth = 64;
constexpr std::size_t kNeuralDefaultDepth = 2;
constexpr int kNeuralDefaultEpochs = 30;
constexpr std::size_t kNeuralDefaultSteps = 18000;
constexpr int kNeuralLeastEpochs = 6;
constexpr std::size_t kNeuralMostSteps = 40000;

// W*H*L + the network's parameters: the neural BTF's stored values on `frame`.
std::uint64_t neural_btf_parameter_count(const ModelFrame& frame, const NeuralShape& shape);

// Fits a neural BTF to a tile: s.components = L (8), s.width (64), s.depth (2) hidden layers,
// s.iterations = the most epochs (passes over the training samples; by default 30, fewer on a
// large tile: detail::neural_default_epochs), s.seed, s.threads
// (the model does not depend on them), s.precision (the latents' storage; the network is
// always 16-bit floats). Adam on minibatches of the training samples; 1 in 20 samples held out
// (model/refine.hpp, validation_sample) choose the parameters kept (the lowest held-out error)
// and when to stop. Throws Error(kArgument) naming the option for a size out of range, and on
// s.stop.
std::unique_ptr<Representation> fit_neural_btf(const Btf& tile, const FitOptions& s);
// Reads NeuralBtf::payload(); Error(kFormat) naming `name`.
std::unique_ptr<Representation> read_neural_btf(std::span<const std::uint8_t> payload,
                                                std::uint32_t flags, const std::string& name);
// Shapes spanning Table 2 ratios from about 1:100 to 1:3000 on `frame`, smallest first, along
// one path: small networks (a latent of 2 or 4, 8 to 32 units) at the low rates, then the
// default network (2 x 64) with a longer latent, L = 2 to 16, then at L = 16 the network
// widened to 96 .. kNeuralWidestRung units, then at that width L = 32 to 128. Two rungs next to
// each other differ in one size where the path allows (its corners are rungs too), so that the
// budget's quick search varies one size between them.
inline constexpr std::size_t kNeuralWidestRung = 256;
std::vector<FitOptions> neural_btf_ladder(const ModelFrame& frame);

// `fit --budget`'s quick search of L (QuickSizeSearch, methods/registry.hpp): a probe is the
// same shape fitted for kNeuralProbeEpochs epoch; the full fit's latents take about
// kNeuralProbeBytesRatio of the bytes of the probe's (the network's 16-bit floats are the same
// count at any epoch): on generated knit 25 x 25 at L = 32, 19.0 KB against 20.0 KB.
inline constexpr int kNeuralProbeEpochs = 1;
inline constexpr double kNeuralProbeBytesRatio = 0.95;
FitOptions neural_byte_probe(const FitOptions& s);
// The model with every latent 0 (the network, frame and provenance kept): its file holds the
// bytes that do not grow with L but through the network's first layer. Throws
// Error(kArgument) for another method's model.
std::unique_ptr<Representation> neural_without_latents(const Representation& model);

}  // namespace btfgmm
