/// \file stages/06-broadphase/step.cu
/// \brief Stage 06 on the GPU: step.cpp's broad phase as a sort of (slab, particle) entries by
/// cell, a neighbour search into one list of pairs, mutual-earliest rounds over that list, and
/// apply. plab::make_gpu_stepper(), which step.cpp's make_stepper() takes when there is a GPU
/// (--device cpu forces step.cpp).
//
// =================================================================================================
//  GOAL   Every phase on the device, as the CUDA sample `particles` does its grid:
//         4. binning: each (slab, particle) entry gets the cell of its position at the slab's
//            midpoint as key; sort the entries by key (CUB); find where each cell starts;
//         5. neighbour search: each entry tests the entries of the cells within its reach and
//            files the pairs that meet in its slab into one list (a fast particle searches more
//            cells: exact for any speed);
//         6. the sparse selection: stage 04's mutual-earliest rounds over the list of pairs.
//         Given (plab/cuda/slab_grid.cuh): the grid's choice, the device arrays, the steps
//         recorded once as a CUDA graph, and the redo of a step whose pairs overflow the list.
//  READ   handouts/06-broadphase.md     TEST   ./plab test --impl student --stage 06 (GPU)
// =================================================================================================
#include <memory>

#include "launchers.cuh"
#include "plab/cuda/slab_grid.cuh"
#include "plab/stage.hpp"

namespace plab {
namespace {

constexpr double kAlpha = 1.0;  //!< slabs per sqrt(N) mean speed / L (--sweep-alpha sets another)

/// A run of stage 06 on the GPU: the kernels of one step (cuda::SlabGridStepper does the rest).
class CudaStepper final : public cuda::SlabGridStepper {
 public:
  using SlabGridStepper::SlabGridStepper;

 private:
  void queue_kernels(const kernels::StepArrays& a) override {
    launch::start_step(n_, a, main_);
    launch::bin(p_.view(), a, grid_, entries_, temp_.get(), temp_.size(), main_);
    launch::find_pairs(p_.view(), box_, a, grid_, entries_, main_);
    launch::select_pairs(a, main_);
    launch::apply(p_.view(), box_, a, main_);
  }
};

}  // namespace

/// Stage 06's GPU path (stage.hpp): a run on the GPU when one can be used; nullptr otherwise
/// (step.cpp's make_stepper() then runs the CPU path), NoDevice when the run asked for the GPU.
std::unique_ptr<Stepper> make_gpu_stepper(const Box& box, Particles& p,
                                          const StageOptions& options) {
  if (options.device == Device::kAuto && !cuda::missing_device().empty()) return nullptr;
  return std::make_unique<CudaStepper>(cuda::require_device(), box, p,
                                       options.sweep_alpha > 0 ? options.sweep_alpha : kAlpha);
}

}  // namespace plab
