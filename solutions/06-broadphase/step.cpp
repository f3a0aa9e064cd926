/// \file solutions/06-broadphase/step.cpp
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
void BroadPhase::bin(const Particles& p, int k) {
  // EXERCISE 1: the binning. In parallel, each particle's cell at the slab's midpoint time (-1 for
  // one that takes no part); then count the particles of each cell, turn the counts into each
  // cell's first entry (prefix sums: start_), and scatter each particle to its cell's next free
  // entry (id_, and its midpoint position in x_, y_).
  const int n = static_cast<int>(p.size()), cells = g_.cells();
  const double tm = g_.slab_mid(k);
#pragma omp parallel for
  for (int i = 0; i < n; ++i)
    cell_[i] = last_[i] < k ? -1 : g_.cell_of(p.x[i] + tm * p.vx[i], p.y[i] + tm * p.vy[i]);
  std::fill(start_.begin(), start_.end(), 0);
  for (int i = 0; i < n; ++i)
    if (cell_[i] >= 0) ++start_[cell_[i] + 1];
  for (int c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  next_.assign(start_.begin(), start_.end() - 1);
  for (int i = 0; i < n; ++i) {
    if (cell_[i] < 0) continue;
    const int e = next_[cell_[i]]++;
    id_[e] = i;
    x_[e] = p.x[i] + tm * p.vx[i];
    y_[e] = p.y[i] + tm * p.vy[i];
  }
}

/// Slab k's pairs: each pair that meets in slab k (model.md's pair time, before both walls), once,
/// into the thread's found_.
void BroadPhase::search(const Box& box, const Particles& p, int k) {
  // EXERCISE 2: the neighbour search. In parallel over the entries: particle i searches every cell
  // within d of its midpoint position along both axes (g_.indices_within()), where d covers any
  // partner no faster than i: they are at most 2r + h(|v_i| + |v_j|) <= 2r + 2h|v_i| apart, plus
  // the margins for rounding (g_.reach is 2r and one margin; the midpoint positions take one more
  // g_.margin). Test each partner within d and no faster than i (equal speeds: the higher index)
  // with model.md's pair time, and keep the event if it is in the step, before both walls and in
  // this slab (the same pair may be near in other slabs too).
  const int taking = start_[g_.cells()];
#pragma omp parallel
  {
    std::vector<model::Event>& found = found_[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 64)
    for (int a = 0; a < taking; ++a) {
      const int i = id_[a];
      const double d = (g_.reach + g_.margin + 2 * g_.half * std::sqrt(speed2_[i])) * (1 + 1e-9);
      int x0, x1, y0, y1;
      g_.indices_within(x_[a], d, x0, x1);
      g_.indices_within(y_[a], d, y0, y1);
      for (int row = y0; row <= y1; ++row) {
        const int to = start_[row * g_.side + x1 + 1];
        for (int b = start_[row * g_.side + x0]; b < to; ++b) {
          const double dx = x_[b] - x_[a], dy = y_[b] - y_[a];
          if (!(dx * dx + dy * dy <= d * d)) continue;  // too far apart to meet in this slab
          const int j = id_[b];
          if (!(speed2_[j] < speed2_[i] || (speed2_[j] == speed2_[i] && j > i))) continue;
          const model::Event e = pair_candidate(box, p, std::min(i, j), std::max(i, j));
          if (model::in_step(e.t) && model::before_walls(e.t, wall_[e.lo], wall_[e.hi]) &&
              g_.slab_of(e.t) == k)
            found.push_back(e);
        }
      }
    }
  }
}

/// model.md's selection over the pairs found and the walls: plan_.
void BroadPhase::select(int n) {
  // EXERCISE 3: the sparse selection. Gather every thread's pairs, sort them by model.md's key,
  // and accept each pair whose particles are both still free. Every pair found comes before both
  // its particles' walls, so no wall can take a particle first: once the pairs are done, each
  // particle left free takes its wall when its wall time is in the step.
  pairs_.clear();
  for (const auto& f : found_) pairs_.insert(pairs_.end(), f.begin(), f.end());
  std::sort(pairs_.begin(), pairs_.end(), model::key_less);
  plan_.reset(n);
  for (const model::Event& e : pairs_)
    if (!plan_.taken(e.lo) && !plan_.taken(e.hi)) plan_.accept(e);
  for (int i = 0; i < n; ++i)
    if (!plan_.taken(i) && model::in_step(wall_[i])) plan_.partner[i] = Plan::kWall;
}

}  // namespace

/// Stage 06's entry point (stage.hpp): the GPU path (step.cu) when the run and the machine allow
/// it, otherwise a BroadPhase steps on the CPU.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  return cpu_stage(box, p, options, std::make_unique<BroadPhase>(), make_gpu_stepper);
}

}  // namespace plab
