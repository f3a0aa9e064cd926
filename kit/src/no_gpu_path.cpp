/// \file no_gpu_path.cpp
/// \brief The stand-in for a stage's GPU path when the kit is built without a CUDA compiler:
/// linked into a stage whose `stage.json` lists `cuda_sources` in place of those sources.
#include "plab/stage.hpp"

namespace plab {

std::unique_ptr<Stepper> make_gpu_stepper(const Box&, Particles&, const StageOptions& options) {
  if (options.device == Device::kGpu)
    throw NoDevice("stage " + stage_info().id + " was built without its GPU path (no CUDA compiler)");
  return nullptr;
}

}  // namespace plab
