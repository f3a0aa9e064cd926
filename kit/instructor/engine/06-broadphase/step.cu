/// \file kit/instructor/engine/06-broadphase/step.cu
/// \brief Stage 06 on the GPU: the broad phase of step.cpp as a counting sort on the device, the
/// pair search over neighbouring buckets into compact candidates, stage 05's rounds and apply;
/// one CUDA graph per step.
/// plab::make_gpu_stepper(), which step.cpp's make_stepper() takes when there is a GPU
/// (--device cpu forces step.cpp).
//
// =================================================================================================
//  GOAL   step.cpp's idea with every phase on the device and no host round trip in a step:
//         start_step (wall times, last slabs, counters) -> per pass of a few slabs: bin_count ->
//         CUB scan -> bin_scatter -> find_pairs; then CUB scan of the counts -> place_pairs ->
//         start_rounds -> resolve -> apply, recorded once as a graph (from kFinishSmallFrom to
//         kGridResolveFrom particles, everything after the passes is one cooperative kernel,
//         finish_small, with grid barriers between its phases, each thread's particle's events in
//         its registers, read from the slots the search filed them in). The grid is chosen on the
//         host from the first state; particles that get faster than v_cut search wider, so it stays
//         exact for any speed. The search reads entries rounded to float and tests them in single
//         precision (sweep::close_in_slab_single(): it passes every pair the double test would);
//         the pair times stay the model's, in double. Small scenes (below kBandedBelow, where a band's entries fit a
//         block's shared memory) skip the passes: one kernel, find_pairs_banded, sorts and searches
//         every slab's bands of rows in shared memory, from each particle's cell in every slab
//         (start_step writes them; the bands launch as start_step's programmatic dependents). A step with more pairs than the list holds (or a band that
//         outgrew its block) stops the batch on the device, and the host redoes it with a longer
//         list (or with the passes). Below kFinishSmallFrom, one block (finish_block) does the rows
//         and the rounds in shared memory, then apply.
//  READ   handouts/engine.md    TEST   ./plab test --impl engine --stage 06 (on a GPU machine)
// =================================================================================================
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "launchers.cuh"
#include "plab/cuda/stepper.hpp"
#include "plab/stage.hpp"

namespace plab {
namespace {

/// Slabs per sqrt(N) v_cut / L (sweep::choose()), measured best on an H200 with float entries
/// (handouts/engine-gpu.md, "The pass search in float"): a scene searched in bands (the report's
/// scene: 0.45 and 0.5 alike, 16% to 28% slower on both sides)...
constexpr double kAlphaBands = 0.5;
/// ... one sorted over the grid below 10^5 particles (N = 1.6 x 10^4 and 4 x 10^4: 0.35 to 0.5
/// alike, 0.27 5% to 12% slower) ...
constexpr double kAlphaPasses = 0.35;
/// ... and from 10^5 (N = 10^6 at the report's density: 0.22 takes 0.78 of 0.5's time, 0.35
/// 0.86; 10^5: 0.22 to 0.35 alike, 0.81 of 0.5's).
constexpr double kAlphaLarge = 0.25;
constexpr int kLargeFrom = 100000;  //!< particles from which kAlphaLarge
/// Entries (particle, slab) one pass of the counting sort holds at most: a step takes as many
/// passes as this needs (one up to N = 10^5 at the report's density, every slab alone from
/// N = 10^6), so that memory grows with N, not with N times the slabs. One pass or nine made no
/// measurable difference at N = 10^6 on an H100 (a few kernel launches more a step).
constexpr long long kEntriesPerPass = 1 << 20;

/// Whether PLAB_ENGINE_KERNELS=separate asks small scenes for the separate kernels after the
/// passes (scan, place_pairs, start_rounds, the one-block resolve, apply) instead of
/// finish_small or finish_block: to measure the difference.
bool separate_asked() {
  const char* v = std::getenv("PLAB_ENGINE_KERNELS");
  return v && std::string(v) == "separate";
}

/// Whether PLAB_ENGINE_BESIDE=off asks a small pass to search its fast entries after the slow ones
/// (as a large pass does) rather than beside them: to measure the difference.
bool beside_off() {
  const char* v = std::getenv("PLAB_ENGINE_BESIDE");
  return v && std::string(v) == "off";
}

/// What PLAB_ENGINE_BANDED asks of a small scene's search in bands (find_pairs_banded()): `off`,
/// the counting sort over the grid and its searches instead (to measure the difference);
/// `narrow`, a halo of one row (so that fast entries search the whole slab: to test that path);
/// `cramped`, 1 KB of shared memory a block, for finish_block() too (so that the first step stops
/// and the host goes back to the sort and the separate kernels: to test that path); anything
/// else, or unset: the bands where they fit.
std::string banded_asked() {
  const char* v = std::getenv("PLAB_ENGINE_BANDED");
  return v ? v : "";
}

/// The pair search's shape for `n` particles: PLAB_ENGINE_SEARCH=batched, lean or balanced when it
/// asks (to measure the difference), otherwise batched below `balanced_from` particles and
/// balanced from there.
kernels::Search search_shape(int n, int balanced_from) {
  const char* v = std::getenv("PLAB_ENGINE_SEARCH");
  if (v && std::string(v) == "batched") return kernels::Search::kBatched;
  if (v && std::string(v) == "lean") return kernels::Search::kLean;
  if (v && std::string(v) == "balanced") return kernels::Search::kBalanced;
  return n < balanced_from ? kernels::Search::kBatched : kernels::Search::kBalanced;
}

/// The device's memory bandwidth in bytes a second: the best of three device-to-device copies
/// of 256 MiB (each byte read once and written once), timed by CUDA events on `stream`; 0 when
/// the memory for it cannot be had. What plab bench sets a step's time against.
double measure_bandwidth(cudaStream_t stream) {
  constexpr std::size_t kBytes = std::size_t{256} << 20;
  void* from = nullptr;
  void* to = nullptr;
  if (cudaMalloc(&from, kBytes) != cudaSuccess) return 0;
  if (cudaMalloc(&to, kBytes) != cudaSuccess) {
    PLAB_CUDA_CHECK(cudaFree(from));
    return 0;
  }
  PLAB_CUDA_CHECK(cudaMemsetAsync(from, 1, kBytes, stream));
  cudaEvent_t start, stop;
  PLAB_CUDA_CHECK(cudaEventCreate(&start));
  PLAB_CUDA_CHECK(cudaEventCreate(&stop));
  float best = 0;
  for (int k = 0; k < 3; ++k) {
    PLAB_CUDA_CHECK(cudaEventRecord(start, stream));
    PLAB_CUDA_CHECK(cudaMemcpyAsync(to, from, kBytes, cudaMemcpyDeviceToDevice, stream));
    PLAB_CUDA_CHECK(cudaEventRecord(stop, stream));
    PLAB_CUDA_CHECK(cudaEventSynchronize(stop));
    float ms = 0;
    PLAB_CUDA_CHECK(cudaEventElapsedTime(&ms, start, stop));
    if (k == 0 || ms < best) best = ms;
  }
  PLAB_CUDA_CHECK(cudaEventDestroy(start));
  PLAB_CUDA_CHECK(cudaEventDestroy(stop));
  PLAB_CUDA_CHECK(cudaFree(from));
  PLAB_CUDA_CHECK(cudaFree(to));
  return best > 0 ? 2.0 * kBytes / (best * 1e-3) : 0;
}

/// A run of stage 06 on the GPU (the kit's cuda::DeviceStepper holds the particles, the flags
/// and the timer, and reads the state back).
class CudaStepper final : public cuda::DeviceStepper<kernels::Flags> {
 public:
  CudaStepper(const Box& box, const Particles& p, std::string device, double alpha)
      : DeviceStepper(std::move(device), box, p, cuda::Queue::kOwnStream), asked_alpha_(alpha),
        wall_(n_), last_(n_), slots_(n_, n_ / 4 + 1024) {  // the list grown as needed
    bandwidth_ = measure_bandwidth(main_);
    set_grid(p);
    if (n_ >= kGridResolveFrom) {
      grid_blocks_ = launch::resolve_grid_blocks();
    } else {
      finish_small_ = n_ >= kFinishSmallFrom && !separate_asked() && launch::finish_small_fits(n_);
      if (finish_small_) slot_.resize(static_cast<std::size_t>(n_) * cuda::CompactView::kSlotted);
      choose_finish_block();
    }
    sync();
  }

  void step() override {
    DeviceStepper::step();
    // A stop on the device (a longer list) idles every later step until the host looks: look
    // after the first step (the list's first length is a guess) and then every kCheckEvery
    // steps, so that at most that many are redone.
    if (n_ > 0 && (asked_ == 1 || asked_ % kCheckEvery == 0)) catch_up();
  }

  [[nodiscard]] double memory_bandwidth() const override { return bandwidth_; }

 private:
  /// One step: the recorded graph (recorded again after the arrays changed).
  void queue_step() override {
    if (stale_) {
      graph_.record(main_, [this] { queue_kernels(); });
      stale_ = false;
    }
    graph_.launch(main_);
  }

  /// The kernels of one step.
  void queue_kernels() {
    const auto a = arrays();
    if (banded_) {  // no sort over the grid: every slab's bands in one kernel
      kernels::DeviceGrid all = grid_;
      all.first = 0;
      all.slabs = grid_.g.slabs;
      launch::start_step(p_.view(), box_, a, all, 0, main_);
      launch::find_pairs_banded(p_.view(), box_, a, all, band_, bands_, shared_bytes_,
                                banded_asked() == "narrow" ? 1 : grid_.g.rows, main_);
    } else {
      queue_passes(a);
    }
    queue_finish(a);
  }

  /// The counting sort over the grid and the pair search, a pass of per_pass_ slabs at a time.
  void queue_passes(const kernels::StepArrays& a) {
    // A step of one pass (small scenes): start_step clears what the pass would clear itself.
    const bool one_pass = per_pass_ >= grid_.g.slabs;
    launch::start_step(p_.view(), box_, a, grid_, one_pass ? grid_.g.slabs * grid_.cells + 1 : 0,
                       main_);
    for (int first = 0; first < grid_.g.slabs; first += per_pass_) {
      kernels::DeviceGrid pass = grid_;
      pass.first = first;
      pass.slabs = std::min(per_pass_, grid_.g.slabs - first);
      const int buckets = pass.slabs * grid_.cells + 1;
      if (!one_pass)
        PLAB_CUDA_CHECK(cudaMemsetAsync(a.start, 0, buckets * sizeof(int), main_));
      launch::bin_count(p_.view(), a, pass, main_);
      cuda::exclusive_scan(a.start, a.start, buckets, temp_.get(), temp_.size(), main_);
      launch::bin_scatter(p_.view(), a, pass, main_);
      if (beside_) {  // the fast entries' search on side_, beside the slow ones' (a small pass)
        PLAB_CUDA_CHECK(cudaEventRecord(sorted_.e, main_));
        PLAB_CUDA_CHECK(cudaStreamWaitEvent(side_, sorted_.e));
        launch::find_pairs_beside(p_.view(), box_, a, pass, search_, main_, side_);
        PLAB_CUDA_CHECK(cudaEventRecord(searched_.e, side_));
        PLAB_CUDA_CHECK(cudaStreamWaitEvent(main_, searched_.e));
      } else {
        launch::find_pairs(p_.view(), box_, a, pass, one_pass, search_, main_);
      }
    }
  }

  /// Everything after the pair search: the rows, the rounds and apply.
  void queue_finish(const kernels::StepArrays& a) {
    if (finish_block_) {  // the rows and the rounds in one block, then apply on the whole GPU
      launch::finish_block(n_, a, finish_bytes_, main_);
      launch::apply(p_.view(), box_, a, main_);
      return;
    }
    if (finish_small_) {  // the scan, place_pairs, start_rounds, the rounds and apply in one
      launch::finish_small(p_.view(), box_, a, main_);
      return;
    }
    cuda::exclusive_scan(a.slots.count, a.slots.end, n_, temp_.get(), temp_.size(), main_);
    launch::place_pairs(a, main_);
    launch::start_rounds(n_, a, main_);
    if (n_ >= kGridResolveFrom)
      launch::resolve_grid(n_, a, grid_blocks_, main_);
    else
      launch::resolve(n_, a, main_);
    launch::apply(p_.view(), box_, a, main_);
  }

  /// Waits for the queued steps; redoes those a stop on the device skipped (a longer list).
  void catch_up() override {
    for (;;) {
      const kernels::Flags f = flags_.read(main_);
      if (f.steps_done == asked_ || (f.overflow == 0 && f.crowded == 0)) return;
      if (f.crowded) {  // a small scene's kernel did not fit its block: the general ones from now
        if (f.crowded & kernels::kCrowdedBands) banded_ = false;  // the sort over the grid
        if (f.crowded & kernels::kCrowdedFinish) finish_block_ = false;
        stale_ = true;
        flags_.clear(&kernels::Flags::crowded, main_);
      }
      if (f.overflow) {
        slots_.grow(2 * f.overflow, main_);
        lay_out();  // the rows are as long as the list (phases_ is allocated again)
        stale_ = true;  // the recorded graph holds the old list's and phases' addresses
        flags_.clear(&kernels::Flags::overflow, main_);  // the stop
      }
      for (long long s = f.steps_done; s < asked_; ++s) queue_step();
      timer_.stop(main_);
    }
  }

  /// The grid for the state `p` (sweep::choose(), the fastest 10% search wider): the bands'
  /// slabs first, and when the scene is not searched in bands (choose_bands()) the passes'; the
  /// slabs a pass takes (kEntriesPerPass), and the arrays of both phases (lay_out()).
  void set_grid(const Particles& p) {
    sync();
    std::vector<double> end(p.size());
    for (std::size_t i = 0; i < p.size(); ++i)
      end[i] = sweep::path_end(model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box_.L, box_.r));
    // No speed of the run exceeds the square root of the summed squared speeds (elastic
    // collisions and walls keep the sum), which bounds the float entries' rounding.
    double energy = 0;
    for (std::size_t i = 0; i < p.size(); ++i) energy += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i];
    const double vbound = std::sqrt(energy) * (1 + 1e-6);
    const bool asked = asked_alpha_ > 0;
    take_grid(p, end, vbound, asked ? asked_alpha_ : kAlphaBands);
    choose_bands(p);
    if (!banded_ && !asked)  // sorted over the grid: that path's own slabs
      take_grid(p, end, vbound, n_ >= kLargeFrom ? kAlphaLarge : kAlphaPasses);
    band_cell_.resize(banded_ ? static_cast<std::size_t>(n_) * grid_.g.slabs : 0);
    const int size = per_pass_ * grid_.cells + 1;
    temp_.resize(std::max(cuda::exclusive_scan_bytes(size), cuda::exclusive_scan_bytes(n_)));
    lay_out();
    stale_ = true;
  }

  /// The grid for the state `p` whose paths end at `end`, with `alpha` slabs per
  /// sqrt(N) v_cut / L, its single-precision test for speeds up to `vbound`, and the slabs a
  /// pass takes: as few passes as kEntriesPerPass allows, the slabs spread evenly over them.
  void take_grid(const Particles& p, const std::vector<double>& end, double vbound,
                 double alpha) {
    std::vector<double> scratch;
    grid_.g = sweep::choose(box_, p, end, scratch, 0.9, alpha);
    grid_.single = sweep::single_of(grid_.g, box_.L, vbound);
    grid_.cells = grid_.g.cells();
    const long long most = std::max<long long>(1, kEntriesPerPass / std::max(n_, 1));
    const int passes = static_cast<int>((grid_.g.slabs + most - 1) / most);
    per_pass_ = (grid_.g.slabs + passes - 1) / passes;
    beside_ = passes == 1 && static_cast<long long>(n_) * per_pass_ < launch::kSmallPass &&
              n_ < kBesideBelow && !beside_off();
  }

  /// Whether a small scene searches in bands (find_pairs_banded()), and how: the rows of a slab
  /// split among the GPU's multiprocessors (a block each, every slab's blocks at once); taken
  /// when the entries a block keeps, with the halo of the first state's fastest particle, fit
  /// in two thirds of its shared memory.
  void choose_bands(const Particles& p) {
    banded_ = false;
    const std::string asked = banded_asked();
    if (n_ == 0 || n_ >= kBandedBelow || asked == "off") return;
    const sweep::Grid& g = grid_.g;
    if (!(g.cell < HUGE_VAL)) return;  // one cell: no geometry to trust
    int device = 0, sms = 0;
    PLAB_CUDA_CHECK(cudaGetDevice(&device));
    PLAB_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
    shared_bytes_ = launch::all_shared_bytes(kernels::find_pairs_banded);
    // A block a multiprocessor (one wave of blocks, when there are no more slabs than
    // multiprocessors); when a band and its halo do not fit, bands of fewer rows: up to
    // kBandWavesMost times as many blocks. (The fit is estimated from the average density: a
    // band denser than that stops the first step, and the host goes back to the sort.)
    const auto split = [&](int waves) {
      const int per_slab = std::max(1, sms / g.slabs) * waves;  // blocks a slab
      band_ = (g.rows + per_slab - 1) / per_slab;
      bands_ = (g.rows + band_ - 1) / band_;
    };
    split(1);
    if (asked == "cramped") {
      shared_bytes_ = 1024;
      banded_ = true;
      return;
    }
    double vmax2 = 0;
    for (std::size_t i = 0; i < p.size(); ++i)
      vmax2 = std::max(vmax2, p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i]);
    const double out = kernels::halo_rows(g, std::sqrt(vmax2));
    if (!(out < HUGE_VAL)) return;
    const int halo = static_cast<int>(std::min<double>(out, g.rows));
    for (int waves = 1; waves <= kBandWavesMost && !banded_; ++waves) {
      split(waves);
      const int rows_kept = std::min(g.rows, band_ + halo + std::max(halo, 1));
      const double cells_bytes = 8.0 * rows_kept * g.columns + 32;
      const double entries = static_cast<double>(n_) * rows_kept / g.rows;
      banded_ = cells_bytes + entries * kernels::kBandEntryBytes < shared_bytes_ * 2.0 / 3.0;
    }
  }

  /// Whether the rows and rounds of a scene below kFinishSmallFrom run in one block
  /// (finish_block()) instead of the separate kernels: when its shared memory holds them for the
  /// list's first length, unless PLAB_ENGINE_KERNELS=separate asks for those (to compare);
  /// PLAB_ENGINE_BANDED=cramped gives it 1 KB, so that the first step stops and the host goes
  /// back to them (to test that path).
  void choose_finish_block() {
    finish_block_ = false;
    if (n_ == 0 || n_ >= kFinishSmallFrom || separate_asked()) return;
    finish_bytes_ = launch::all_shared_bytes(kernels::finish_block);
    if (banded_asked() == "cramped") {
      finish_bytes_ = 1024;
      finish_block_ = true;
      return;
    }
    finish_block_ = kernels::finish_block_bytes(n_, slots_.capacity()) <= finish_bytes_;
  }

  /// Lays the two phases' arrays over one allocation (see `phases_`): the passes' (bucket
  /// starts, ranks, entries) and the rounds' (the candidates' rows, each particle's choice, the
  /// plan), each array on a 256-byte boundary.
  void lay_out() {
    const std::size_t n = static_cast<std::size_t>(n_);
    const std::size_t entries = n * per_pass_;
    const std::size_t buckets = static_cast<std::size_t>(per_pass_) * grid_.cells + 1;
    Carve pass, rounds;
    const std::size_t start = pass.take<int>(buckets), rank = pass.take<int>(entries),
                      entry_at = pass.take<int>(entries),
                      entry = pass.take<kernels::Entry>(entries);
    const std::size_t rows = rounds.take<int>(slots_.rows()), best = rounds.take<model::Event>(n),
                      resolved = rounds.take<char>(n), contested = rounds.take<int>(n),
                      partner = rounds.take<int>(n), ptime = rounds.take<double>(n);
    phases_.resize(std::max(pass.at, rounds.at));
    unsigned char* base = phases_.get();
    on_.start = reinterpret_cast<int*>(base + start);
    on_.rank = reinterpret_cast<int*>(base + rank);
    on_.entry_at = reinterpret_cast<int*>(base + entry_at);
    on_.entry = reinterpret_cast<kernels::Entry*>(base + entry);
    rows_ = reinterpret_cast<int*>(base + rows);
    rows_length_ = slots_.rows();
    on_.best = reinterpret_cast<model::Event*>(base + best);
    on_.resolved = reinterpret_cast<char*>(base + resolved);
    on_.contested = reinterpret_cast<int*>(base + contested);
    on_.partner = reinterpret_cast<int*>(base + partner);
    on_.ptime = reinterpret_cast<double*>(base + ptime);
  }

  [[nodiscard]] std::size_t arrays_bytes() const override {
    return cuda::bytes_of(wall_, last_, slots_, slot_, band_cell_, phases_, temp_);
  }

  /// The step's arrays: those of the two phases (lay_out()) with the ones kept for the run.
  [[nodiscard]] kernels::StepArrays arrays() const {
    kernels::StepArrays a = on_;
    a.wall = wall_.get();
    a.last = last_.get();
    a.slots = slots_.view(rows_, rows_length_);
    a.slots.slot = finish_small_ ? slot_.get() : nullptr;
    a.band_cell = banded_ ? band_cell_.get() : nullptr;
    a.flags = flags_.get();
    return a;
  }

  /// Byte offsets of arrays laid one after the other, each on a 256-byte boundary.
  struct Carve {
    std::size_t at = 0;  //!< bytes laid so far
    /// The offset of an array of `count` T's, laid next.
    template <class T>
    std::size_t take(std::size_t count) {
      const std::size_t here = at;
      at = (at + count * sizeof(T) + 255) / 256 * 256;
      return here;
    }
  };

  static constexpr long long kCheckEvery = 32;  //!< steps between two looks at the flags
  /// Below this N a step may search in bands (choose_bands()).
  static constexpr int kBandedBelow = 1 << 15;
  /// Waves of blocks the bands' search may take (choose_bands()).
  static constexpr int kBandWavesMost = 4;
  static constexpr int kGridResolveFrom = 50000;  //!< from this N the rounds use the whole GPU
  /// From this N to kGridResolveFrom, finish_small() after the passes. Measured on an H100
  /// (2026-11-25, S = 500, the report's box): 3-4% slower than the separate kernels at
  /// N = 1000, 2000 and 4000, 10% faster at 10^4 and 45% at 4 x 10^4; the crossing, about 5000,
  /// is interpolated. Below it, finish_block() where it fits: measured on an H200 (2026-11-28,
  /// S = 500, the report's box, the bands' search, medians of 5, ms a step, one block / the
  /// kernels it replaced or above 5000 finish_small()): N = 1000 0.0248 / 0.0299, 4000 0.0402 /
  /// 0.0424, 10^4 0.0954 / 0.0671, 1.2 x 10^4 0.1407 / 0.0954 (one SM's rounds, each round's
  /// loads from device memory one after another, lose to the whole GPU's).
  static constexpr int kFinishSmallFrom = 5000;
  /// From this N the pair search is balanced rather than batched (kernels::Search). Measured on
  /// an H200 (2026-11-27, ms a step, medians of 5 runs, 3 at 10^6; batched or lean / balanced): N = 4000
  /// 0.061 / 0.063, 10^4 0.090 / 0.089, 2 x 10^4 0.155 / 0.138, 10^5 0.565 / 0.526 and 10^6
  /// 4.650 / 4.363 (lean from 2 x 10^4); handouts/engine-gpu.md has the table.
  static constexpr int kBalancedSearchFrom = 10000;
  /// Below this N a step of one pass searches its fast entries beside the slow ones (beside_).
  /// Measured on an H200 (2026-11-27, the report's box, S = 500, medians of 5 runs, ms a step,
  /// after / beside): N = 1000 0.043 / 0.036, 4000 0.054 / 0.049, 10^4 0.082 / 0.087 (there
  /// the slow search is balanced and fills more of the GPU), 2 x 10^4 0.139 / 0.139.
  static constexpr int kBesideBelow = 10000;
  double bandwidth_ = 0;  //!< measure_bandwidth(), once, before the steps
  double asked_alpha_;  //!< StageOptions::sweep_alpha (0: kAlphaBands, kAlphaPasses or kAlphaLarge)
  kernels::DeviceGrid grid_{};
  int per_pass_ = 1;  //!< slabs one pass of the counting sort takes
  cuda::DeviceArray<double> wall_;
  cuda::DeviceArray<int> last_;
  cuda::DeviceCandidates slots_;
  /// finish_small()'s scenes: each particle's first events as the search files them
  /// (cuda::CompactView::slot), so that a step lays no rows when none has more.
  cuda::DeviceArray<int> slot_;
  /// The arrays of the slab passes (read by the search, dead once it ends) and those of the
  /// rounds and apply (written only after the search) in one allocation, as large as the larger
  /// phase: a step never needs both at once (handouts/engine-gpu.md measures what this saves).
  cuda::DeviceArray<unsigned char> phases_;
  /// Where lay_out() put the arrays of the two phases in `phases_` (the rest of the step's arrays
  /// are set by arrays()), and the candidates' rows (cuda::CompactView::row) with their length.
  kernels::StepArrays on_{};
  int* rows_ = nullptr;
  std::size_t rows_length_ = 0;
  cuda::DeviceArray<unsigned char> temp_;
  cuda::Graph graph_;
  bool stale_ = true;
  int grid_blocks_ = 0;
  /// Small scenes: finish_small() after the passes, unless PLAB_ENGINE_KERNELS=separate asks
  /// for the separate kernels (to compare) or the GPU cannot hold its blocks at once.
  bool finish_small_ = false;
  /// Scenes below kFinishSmallFrom: finish_block() with finish_bytes_ of shared memory, and
  /// apply(), after the search (choose_finish_block()), instead of the separate kernels.
  bool finish_block_ = false;
  int finish_bytes_ = 0;
  /// The pair search's shape (search_shape()).
  kernels::Search search_ = search_shape(n_, kBalancedSearchFrom);
  /// A step of one small pass searches its fast entries on side_ beside the slow ones
  /// (launch::find_pairs_beside()), unless PLAB_ENGINE_BESIDE=off asks otherwise (to compare).
  bool beside_ = false;
  /// A small scene searches in bands of band_ rows, bands_ a slab, with shared_bytes_ of shared
  /// memory a block (choose_bands()), unless PLAB_ENGINE_BANDED=off asks otherwise (to compare).
  bool banded_ = false;
  int band_ = 1, bands_ = 1, shared_bytes_ = 0;
  /// The bands' steps: each particle's cell in every slab (kernels::StepArrays::band_cell).
  cuda::DeviceArray<int> band_cell_;
  cuda::Stream side_;
  /// An event without timing: where side_ starts (the pass sorted) and where main_ waits for it.
  struct Mark {
    cudaEvent_t e = nullptr;
    Mark() { PLAB_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming)); }
    ~Mark() { cudaEventDestroy(e); }
    Mark(const Mark&) = delete;
    Mark& operator=(const Mark&) = delete;
  };
  Mark sorted_, searched_;
};

}  // namespace

/// Stage 06's GPU path (stage.hpp): a run on the GPU when one can be used; nullptr otherwise
/// (step.cpp's make_stepper() then runs the CPU path), NoDevice when the run asked for the GPU.
std::unique_ptr<Stepper> make_gpu_stepper(const Box& box, Particles& p,
                                          const StageOptions& options) {
  if (options.device == Device::kAuto && !cuda::missing_device().empty()) return nullptr;
  return std::make_unique<CudaStepper>(box, p, cuda::require_device(),
                                       options.sweep_alpha);
}

}  // namespace plab
