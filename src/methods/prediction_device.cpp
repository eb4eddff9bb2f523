// Where a model's predictions are computed: the device chosen, offered to the model.
#include "btfgmm/methods/prediction_device.hpp"

#include <fmt/format.h>

#include <memory>

#include "btfgmm/core/error.hpp"
#include "btfgmm/core/text.hpp"

namespace btfgmm {

std::string compute_predictions_on(Representation& model, DeviceChoice choice,
                                   std::string_view name) {
  const std::shared_ptr<ComputeDevice> device =
      choice == DeviceChoice::kCpu ? nullptr : open_compute_device(choice);
  if (!device) {
    model.compute_on(nullptr);
    return "the CPU";
  }
  if (model.compute_on(device)) return "the GPU " + device->info().description();
  if (choice == DeviceChoice::kGpu)
    throw Error(Error::Kind::kArgument,
                fmt::format("{} gpu: {} is a '{}' model, whose predictions are computed on the "
                            "CPU only (the GPU computes those of gm and neural); give {} cpu "
                            "or auto",
                            option_name("device"), name, model.method(), option_name("device")));
  return "the CPU";
}

void compute_where_fitted(Representation& model, const FitOptions& s) {
  const DeviceChoice choice = fit_device(s);
  if (choice != DeviceChoice::kCpu) model.compute_on(open_compute_device(choice));
}

}  // namespace btfgmm
