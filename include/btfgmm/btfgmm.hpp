// btfgmm: measured material appearance (BTFs) compressed into analytic models, evaluated,
// measured and rendered. The umbrella header: every public header, layer by layer
// (docs/ARCHITECTURE.md); see each header for its part.
#pragma once

// core: directions, the BTF container, errors, limits, text, option parsing
#include "btfgmm/core/btf.hpp"
#include "btfgmm/core/directions.hpp"
#include "btfgmm/core/error.hpp"
#include "btfgmm/core/fast_interpolation.hpp"
#include "btfgmm/core/interpolation.hpp"
#include "btfgmm/core/limits.hpp"
#include "btfgmm/core/parse.hpp"
#include "btfgmm/core/text.hpp"
// io: files, images, data sets
#include "btfgmm/io/convert.hpp"
#include "btfgmm/io/dataset.hpp"
#include "btfgmm/io/files.hpp"
#include "btfgmm/io/image.hpp"
#include "btfgmm/io/image_names.hpp"
#include "btfgmm/io/ubo_btf.hpp"
#include "btfgmm/io/utia.hpp"
// model: the mixture, samples, EM, fitting, prediction, the model file, checkpoints
#include "btfgmm/model/checkpoint.hpp"
#include "btfgmm/model/decode.hpp"
#include "btfgmm/model/em.hpp"
#include "btfgmm/model/em_reference.hpp"
#include "btfgmm/model/fit.hpp"
#include "btfgmm/model/mixture.hpp"
#include "btfgmm/model/model.hpp"
#include "btfgmm/model/model_file.hpp"
#include "btfgmm/model/predict.hpp"
#include "btfgmm/model/samples.hpp"
// methods: one interface for every representation (the mixture and the comparison methods)
#include "btfgmm/methods/fit_options.hpp"
#include "btfgmm/methods/gaussian_mixture.hpp"
#include "btfgmm/methods/lpca.hpp"
#include "btfgmm/methods/measured_images.hpp"
#include "btfgmm/methods/pca_btf.hpp"
#include "btfgmm/methods/pca_rf.hpp"
#include "btfgmm/methods/plm_rf.hpp"
#include "btfgmm/methods/ptm_rf.hpp"
#include "btfgmm/methods/registry.hpp"
#include "btfgmm/methods/representation.hpp"
// measure: image quality, a model against its data, the rate-distortion sweep, seamless tiles
#include "btfgmm/measure/compare.hpp"
#include "btfgmm/measure/compare_data.hpp"
#include "btfgmm/measure/metrics.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/measure/tile.hpp"
#include "btfgmm/measure/tile_option.hpp"
// render: meshes, rasterising, evaluators, composing
#include "btfgmm/render/camera.hpp"
#include "btfgmm/render/data_evaluator.hpp"
#include "btfgmm/render/figure.hpp"
#include "btfgmm/render/font.hpp"
#include "btfgmm/render/mesh.hpp"
#include "btfgmm/render/model_evaluator.hpp"
#include "btfgmm/render/rasterize.hpp"
#include "btfgmm/render/render.hpp"
#include "btfgmm/render/representation_evaluator.hpp"
#include "btfgmm/render/shader.hpp"
#include "btfgmm/render/viewer.hpp"
// report: pictures, charts and the HTML report
#include "btfgmm/report/chart.hpp"
#include "btfgmm/report/pictures.hpp"
#include "btfgmm/report/report.hpp"
// synth: generated BTFs
#include "btfgmm/synth/generate.hpp"
