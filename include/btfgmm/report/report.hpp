// The report a person looks at for models compared with the BTF they were fitted to: the
// paper's Fig. 2 (the mean BRDF as an ni x nv image), Fig. 3 (original | model | 10 x
// difference with RMSE / PSNR / SSIM and compression ratios), Fig. 4 (compression ratio
// against tile size) and rate-distortion curves, written as PNG pictures, inline SVG and one
// self-contained index.html (no network, no server). See docs/METRICS.md.
//
// The comparison itself is measure/compare.hpp, the pictures report/pictures.hpp, the curves
// report/chart.hpp; this header includes them.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "btfgmm/measure/compare.hpp"
#include "btfgmm/measure/sweep.hpp"
#include "btfgmm/report/chart.hpp"
#include "btfgmm/report/pictures.hpp"

namespace btfgmm {

// What a report says besides its models.
struct ReportOptions {
  std::string command = "compare";      // the page's title: "btfgmm <command>: <BTF>"
  std::vector<SkippedSetting> skipped;  // a sweep's settings that were not fitted, listed
  std::string note;                     // a line under the title (e.g. how a sweep was run)
  // The first model's tile of the data, for the models side by side (a typical pair is
  // pictured from it); null: that section shows only pairs the first model pictures.
  const Btf* data = nullptr;
};

// Writes `folder`/index.html and its PNG pictures next to it (the folder is created if
// needed; files of the same names are replaced). `btf_name` names the BTF in the title. The
// page: the models' table (with the Pareto front of PSNR against the file's compression
// ratio marked), the curves (rate-distortion per method), one image decoded by each method
// beside the original, the models of the first model's tile side by side at a few (light,
// view) pairs, then a section per model. Throws Error(kArgument) for no models,
// Error(kIo) if a file cannot be written.
void write_report(const std::filesystem::path& folder, const std::string& btf_name,
                  std::span<const ModelComparison> models, const ReportOptions& options = {});

}  // namespace btfgmm
