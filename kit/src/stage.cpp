/// \file stage.cpp
/// \brief The stage interface's kit side: options from the documented environment overrides, and
/// the entry point every CPU stage hands its step() to (plab::cpu_stage()).
#include "plab/stage.hpp"

#include <algorithm>
#include <cstdlib>
#include <sstream>
#include <utility>

namespace plab {
namespace {

/// The Stepper of a CPU stage whose step is an object (CpuStep): it owns the object, and with it
/// the stage's working memory, for the run.
class ObjectStepper final : public Stepper {
 public:
  /// Advances `p` itself (no copy), which must outlive the stepper.
  ObjectStepper(std::unique_ptr<CpuStep> state, const Box& box, Particles& p)
      : state_(std::move(state)), box_(box), p_(&p) {}
  void step() override { state_->step(box_, *p_); }
  void read(Particles& p) override {
    if (&p != p_) p = *p_;
  }

 private:
  std::unique_ptr<CpuStep> state_;
  Box box_;
  Particles* p_;
};

}  // namespace

bool StageOptions::is_off(const std::string& change) const {
  return std::find(off.begin(), off.end(), change) != off.end();
}

StageOptions StageOptions::from_environment() {
  StageOptions o;
  if (const char* d = std::getenv("PLAB_DEVICE")) {
    const std::string device = d;
    if (device == "cpu") o.device = Device::kCpu;
    if (device == "gpu") o.device = Device::kGpu;
  }
  if (const char* s = std::getenv("PLAB_SIMD")) o.simd = s;
  if (const char* off = std::getenv("PLAB_CUDA_OFF")) {
    std::istringstream list(off);
    for (std::string item; std::getline(list, item, ',');)
      if (!item.empty()) o.off.push_back(item);
  }
  if (const char* alpha = std::getenv("PLAB_SWEEP_ALPHA")) o.sweep_alpha = std::atof(alpha);
  return o;
}

std::unique_ptr<Stepper> cpu_stage(const Box& box, Particles& p, const StageOptions& options,
                                   const CpuStage& stage) {
  const StageInfo& info = stage_info();
  if (options.real == Real::kFloat) {
    if (stage.step_float == nullptr)
      throw std::runtime_error("stage " + info.id + " has no float variant (--real float)");
    return std::make_unique<RealStepper<float>>(stage.step_float, box, p);
  }
  if (options.device != Device::kCpu && stage.gpu != nullptr)
    if (auto gpu = stage.gpu(box, p, options)) return gpu;
  if (options.device == Device::kGpu)
    throw NoDevice("stage " + info.id + " has no GPU path (--device gpu)");
  return std::make_unique<HostStepper>(stage.step, box, p);
}

std::unique_ptr<Stepper> cpu_stage(const Box& box, Particles& p, const StageOptions& options,
                                   std::unique_ptr<CpuStep> state, GpuStarter gpu) {
  const StageInfo& info = stage_info();
  if (options.real == Real::kFloat)
    throw std::runtime_error("stage " + info.id + " has no float variant (--real float)");
  if (options.device != Device::kCpu && gpu != nullptr)
    if (auto g = gpu(box, p, options)) return g;
  if (options.device == Device::kGpu)
    throw NoDevice("stage " + info.id + " has no GPU path (--device gpu)");
  return std::make_unique<ObjectStepper>(std::move(state), box, p);
}

}  // namespace plab
