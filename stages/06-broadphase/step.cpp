/// \file stages/06-broadphase/step.cpp
/// \brief Stage 06, broad phase (CPU, OpenMP): a space-time grid finds the pairs that can meet in
/// the step, model.md's pair time is computed for those alone, and the events are chosen in key
/// order over that short list. Same bits as stages 01-05.
//
// =================================================================================================
//  GOAL   Stage 03 tests N^2/2 pairs a step; at N = 10^4 in the report's box only about 2000 can
//         meet. For each time slab of the grid (plab/grid.hpp, given):
//         1. bin the particles that take part into cells by their midpoint positions (a counting
//            sort: count per cell, prefix sums, scatter);
//         2. each particle searches the cells its motion can reach and computes the pair time
//            with each partner no faster than itself, keeping the pairs that meet in this slab;
//         then 3. select events in model.md's key order over the pairs found, walls last, and
//         apply them (given). Memory O(N + cells + pairs found): no N x N anything.
//  READ   handouts/06-broadphase.md     TEST   ./plab test --impl student --stage 06
// =================================================================================================
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "plab/grid.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

/// Stage 06's step, and the working memory it keeps from one step to the next (cpu_stage() makes
/// one a run).
class BroadPhase final : public CpuStep {
 public:
  void step(const Box& box, Particles& p) override;

 private:
  void bin(const Particles& p, int k);
  void search(const Box& box, const Particles& p, int k);
  void select(int n);

  grid::Grid g_;                 //!< this step's grid
  std::vector<double> wall_;     //!< per particle: its wall time
  std::vector<double> speed2_;   //!< its squared speed
  std::vector<int> last_;        //!< the last slab it takes part in (-1: none)
  std::vector<int> cell_;        //!< its cell in the slab being binned (-1: takes no part)
  std::vector<int> start_;       //!< cell c holds entries [start_[c], start_[c + 1])
  std::vector<int> next_;        //!< per cell: where its next entry goes, while scattering
  std::vector<int> id_;          //!< per entry (the slab's particles in cell order): the particle
  std::vector<double> x_, y_;    //!< per entry: the particle's position at the slab's midpoint
  std::vector<std::vector<model::Event>> found_;  //!< each thread's pairs found
  std::vector<model::Event> pairs_;               //!< every pair found in the step
  Plan plan_;                                     //!< the events chosen
};

void BroadPhase::step(const Box& box, Particles& p) {
  const int n = static_cast<int>(p.size());
  for (auto* v : {&wall_, &speed2_, &x_, &y_}) v->resize(n);
  for (auto* v : {&last_, &cell_, &id_}) v->resize(n);
#pragma omp parallel for
  for (int i = 0; i < n; ++i) {
    wall_[i] = wall_candidate(box, p, i).t;
    speed2_[i] = p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i];
  }
  g_ = grid::choose(box, speed2_, wall_);
  for (int i = 0; i < n; ++i) last_[i] = g_.last_slab(wall_[i]);
  start_.resize(static_cast<std::size_t>(g_.cells()) + 1);
  found_.resize(omp_get_max_threads());
  for (auto& f : found_) f.clear();
  for (int k = 0; k < g_.slabs; ++k) {
    bin(p, k);
    search(box, p, k);
  }
  select(n);
#pragma omp parallel for
  for (int i = 0; i < n; ++i) apply_one(box, p, plan_, i);
}

/// Slab k's entries: the particles that take part in it (last_[i] >= k), sorted by the cell of
/// their midpoint position by a counting sort, into id_, x_, y_ and start_.
void BroadPhase::bin([[maybe_unused]] const Particles& p, [[maybe_unused]] int k) {
  // EXERCISE 1: the binning. In parallel, each particle's cell at the slab's midpoint time (-1 for
  // one that takes no part); then count the particles of each cell, turn the counts into each
  // cell's first entry (prefix sums: start_), and scatter each particle to its cell's next free
  // entry (id_, and its midpoint position in x_, y_).
  PLAB_EXERCISE(1, "bin the slab's particles into cells with a counting sort");
}

/// Slab k's pairs: each pair that meets in slab k (model.md's pair time, before both walls), once,
/// into the thread's found_.
void BroadPhase::search([[maybe_unused]] const Box& box, [[maybe_unused]] const Particles& p,
                        [[maybe_unused]] int k) {
  // EXERCISE 2: the neighbour search. In parallel over the entries: particle i searches every cell
  // within a distance d of its midpoint position along both axes (g_.indices_within()). Choose d,
  // and which of a pair's two particles tests it, so that no pair is missed (handout 06, "What you
  // write": fast particles and rounding included). Test each partner with model.md's pair time,
  // and keep the event if it is in the step, before both walls and in this slab (the same pair
  // may be near in other slabs too).
  PLAB_EXERCISE(2, "search the neighbouring cells for the pairs that meet in the slab");
}

/// model.md's selection over the pairs found and the walls: plan_.
void BroadPhase::select([[maybe_unused]] int n) {
  // EXERCISE 3: the sparse selection. Gather every thread's pairs, sort them by model.md's key,
  // and accept each pair whose particles are both still free; then each particle left free takes
  // its wall when its wall time is in the step (handout 06 asks why the walls may come last).
  PLAB_EXERCISE(3, "select the events in key order over the pairs found");
}

}  // namespace

/// Stage 06's entry point (stage.hpp): the GPU path (step.cu) when the run and the machine allow
/// it, otherwise a BroadPhase steps on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, std::make_unique<BroadPhase>(), make_gpu_stepper);
}

}  // namespace plab
