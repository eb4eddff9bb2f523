// Prediction, Eq. (8)-(11), on a compute device (docs/GPU.md, "Decoding on the GPU"): the
// queries' inputs x_I in model units and each component's parameters uploaded, the conditional
// expectation of the colour (Eq. 8-10) summed by predict_colours.comp, Eq. (11) on the host.
// The equations are model/conditional.hpp's; predict.cpp and decode.cpp sum them on the CPU.
#include "btfgmm/model/predict_gpu.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "btfgmm/core/error.hpp"
#include "gpu/device_check.hpp"
#include "model/conditional.hpp"
#include "model/gpu_passes.hpp"

namespace btfgmm {
namespace {

constexpr std::uint32_t kPredictGroup = 64;  // predict_colours.comp's local size

struct PredictPush {
  std::uint32_t components, pixels, views, grid, first, count;
  float period_x, period_y;
};

// The inputs of predict_colours.comp: rows of the pixel's (x, y), the light's and the view's
// angles (alpha, beta), in model units. On the grid, query i is pixel i % pixels of image
// i / pixels (light-major); otherwise query i has row i of each.
struct QueryInputs {
  std::vector<float> pixel_xy, light_ab, view_ab;
  std::size_t queries = 0, pixels = 0, views = 0;
  bool grid = false;
};

void add_angles(std::vector<float>& to, const Direction& d, const BtfModel& model, int n) {
  const detail::AngleInputs a = detail::angle_inputs(d, model.scaling.unit, n);
  to.push_back(float(a.alpha));
  to.push_back(float(a.beta));
}

QueryInputs query_rows(const BtfModel& model, std::span<const Query> queries) {
  QueryInputs in;
  in.queries = in.pixels = in.views = queries.size();
  for (const Query& q : queries) {
    double x[kInputs];
    detail::query_inputs(model, q, x);
    in.pixel_xy.insert(in.pixel_xy.end(), {float(x[0]), float(x[1])});
    in.light_ab.insert(in.light_ab.end(), {float(x[2]), float(x[3])});
    in.view_ab.insert(in.view_ab.end(), {float(x[4]), float(x[5])});
  }
  return in;
}

QueryInputs grid_rows(const BtfModel& model, const DirectionSet& lights,
                      const DirectionSet& views) {
  QueryInputs in;
  in.grid = true;
  in.pixels = std::size_t(model.width) * std::size_t(model.height);
  in.views = views.size();
  in.queries = in.pixels * lights.size() * views.size();
  for (int y = 0; y < model.height; ++y)
    for (int x = 0; x < model.width; ++x)
      in.pixel_xy.insert(in.pixel_xy.end(), {float(x), float(y)});
  for (const Direction& d : lights) add_angles(in.light_ab, d, model, 2);
  for (const Direction& d : views) add_angles(in.view_ab, d, model, 4);
  return in;
}

// Eq. (8)'s colour in model units of every query (3 floats a query), in runs of at most
// `per_run` queries. Refused before any transfer where the device cannot hold the work.
std::vector<float> conditional_colours(ComputeDevice& device, const BtfModel& model,
                                       const QueryInputs& in, std::size_t per_run) {
  const std::size_t m = model.mixture.size();
  if (in.queries > std::numeric_limits<std::uint32_t>::max())
    throw Error(Error::Kind::kArgument,
                fmt::format("{} queries at once are more than the GPU's prediction numbers "
                            "(2^32 - 1); decode fewer images at once",
                            in.queries));
  const std::size_t run = std::max<std::size_t>(1, std::min(in.queries, per_run));
  const double bytes = 80.0 * double(m) +
                       4.0 * double(in.pixel_xy.size() + in.light_ab.size() + in.view_ab.size()) +
                       12.0 * double(run);
  detail::check_device_holds(device.info(), bytes, std::max(12.0 * double(run), 80.0 * double(m)),
                             fmt::format("the predictions of {} queries", in.queries));
  detail::check_loop_nest(device.info(), m, "the prediction's sum over the components");
  const auto components = detail::uploaded(device, detail::component_vectors(model.mixture));
  const auto pixel_xy = detail::uploaded(device, in.pixel_xy),
             light_ab = detail::uploaded(device, in.light_ab),
             view_ab = detail::uploaded(device, in.view_ab);
  const auto colours = device.buffer(run * 3 * sizeof(float));
  const auto kernel = device.kernel("predict_colours.spv", 5, sizeof(PredictPush));
  const detail::Periods periods = detail::model_periods(model);
  std::vector<float> out(in.queries * 3);
  GpuBuffer* bound[] = {components.get(), pixel_xy.get(), light_ab.get(), view_ab.get(),
                        colours.get()};
  for (std::size_t first = 0; first < in.queries; first += run) {
    const std::size_t count = std::min(run, in.queries - first);
    const PredictPush push{std::uint32_t(m),        std::uint32_t(in.pixels),
                           std::uint32_t(in.views), std::uint32_t(in.grid),
                           std::uint32_t(first),    std::uint32_t(count),
                           float(periods[0]),       float(periods[1])};
    const auto [gx, gy] = detail::groups_for(count, kPredictGroup);
    device.run(*kernel, bound, detail::bytes_of(push), gx, gy);
    device.download_values<float>(*colours, std::span(out).subspan(first * 3, count * 3));
  }
  return out;
}

// Eq. (11) for one query: the colour in model units times the unit plus the mean BRDF.
void add_mean_brdf(const BtfModel& model, const std::array<float, 3>& mean_brdf, float* rgb) {
  for (std::size_t c = 0; c < 3; ++c)
    rgb[c] = float(
        detail::predicted_value(double(rgb[c]), model.scaling.unit[6 + c], double(mean_brdf[c])));
}

}  // namespace

void predict(ComputeDevice& device, const BtfModel& model, std::span<const Query> queries,
             std::span<float> rgb) {
  if (rgb.size() < queries.size() * 3)
    throw Error(Error::Kind::kArgument, "predict: the output holds fewer than 3 floats a query");
  detail::check_queries(queries);
  if (queries.empty()) return;
  const std::vector<float> colours =
      conditional_colours(device, model, query_rows(model, queries), kGpuDecodeQueries);
  const detail::MeanBrdfInterpolator mean(model);
  for (std::size_t i = 0; i < queries.size(); ++i) {
    std::copy_n(&colours[i * 3], 3, &rgb[i * 3]);
    add_mean_brdf(model, mean.at(queries[i].light, queries[i].view), &rgb[i * 3]);
  }
}

Btf decode(ComputeDevice& device, const BtfModel& model, const DirectionSet& lights,
           const DirectionSet& views, int width, int height, std::size_t queries_per_run) {
  detail::check_decode_request(lights, views, width, height);
  limits::check_memory(double(lights.size()) * double(views.size()) *
                           (double(width) * height + double(model.width) * model.height) * 12.0,
                       fmt::format("decoding {} images of {}x{} pixels on the GPU",
                                   lights.size() * views.size(), width, height),
                       "decode a smaller size (`size`) or fewer directions (`light`, `view`)");
  Btf out(lights, views, width, height, model.format);
  if (lights.size() * views.size() == 0) return out;
  std::vector<float> tiles =
      conditional_colours(device, model, grid_rows(model, lights, views), queries_per_run);
  const detail::MeanBrdfInterpolator mean(model);
  const std::size_t pixels = std::size_t(model.width) * std::size_t(model.height);
  for (std::size_t l = 0; l < lights.size(); ++l)
    for (std::size_t v = 0; v < views.size(); ++v) {
      float* tile = &tiles[(l * views.size() + v) * pixels * 3];
      const std::array<float, 3> mb = mean.at(lights[l], views[v]);
      for (std::size_t p = 0; p < pixels; ++p) add_mean_brdf(model, mb, tile + p * 3);
      detail::repeat_tile(tile, model.width, model.height, width, height, out.image(l, v));
    }
  return out;
}

}  // namespace btfgmm
