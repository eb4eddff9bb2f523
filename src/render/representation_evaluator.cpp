// Any representation at many surface points (representation_evaluator.hpp).
#include "btfgmm/render/representation_evaluator.hpp"

#include <vector>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/render/rasterize.hpp"

namespace btfgmm {

RepresentationEvaluator::RepresentationEvaluator(std::shared_ptr<const Representation> model,
                                                 double tolerance)
    : model_(std::move(model)) {
  if (const auto* gm = dynamic_cast<const GaussianMixture*>(model_.get()))
    mixture_ = std::make_unique<ModelEvaluator>(gm->model(), tolerance);
}

RepresentationEvaluator::~RepresentationEvaluator() = default;
RepresentationEvaluator::RepresentationEvaluator(RepresentationEvaluator&&) noexcept = default;
RepresentationEvaluator& RepresentationEvaluator::operator=(RepresentationEvaluator&&) noexcept =
    default;

namespace {

// A surface point as a query of predict(): its tile position and its local light and view.
Query query_of(const SurfacePoint& p) {
  Query q;
  q.x = p.x;
  q.y = p.y;
  q.light = to_direction(Vec3{p.light[0], p.light[1], p.light[2]});
  q.view = to_direction(Vec3{p.view[0], p.view[1], p.view[2]});
  if (q.view.theta_deg > 90.0) q.view.theta_deg = 90.0;  // a grazing view, rounded below z = 0
  return q;
}

}  // namespace

EvaluationStats RepresentationEvaluator::evaluate(std::span<const SurfacePoint> points,
                                                  std::span<float> rgb,
                                                  std::span<const std::uint32_t> groups) const {
  if (mixture_) return mixture_->evaluate(points, rgb, groups);
  if (rgb.size() < points.size() * 3)
    throw Error(Error::Kind::kArgument, "evaluate: the output holds fewer than 3 floats a point");
  const auto t0 = Clock::now();
  std::vector<Query> queries(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) queries[i] = query_of(points[i]);
  model_->predict(queries, rgb);
  EvaluationStats st;
  st.points = points.size();
  st.nominal = st.evaluated = points.size();
  st.seconds = seconds_since(t0);
  return st;
}

}  // namespace btfgmm
