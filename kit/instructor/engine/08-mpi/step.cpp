/// \file kit/instructor/engine/08-mpi/step.cpp
/// \brief Stage 08's engine (instructor-only: the kit's fast version of the stage, whose code
/// holds the answers of stage 08's exercises and of earlier stages'): the box cut into blocks, one
/// per rank (Blocks); each rank steps the particles whose centre lies in its block, with copies of the other
/// ranks' particles that can meet them before their walls (the halo), finds its candidates with
/// stage 06's space-time grid (on the CPU, or on one GPU per rank: step.cu), chooses the events by
/// stage 03's mutual-earliest rounds across ranks, sharing only the values of the ghosts that are
/// some owned particle's candidate partner, and hands the particles that left its block to their
/// new owners. Same bits as stages 01-06 at any rank count. handouts/engine-08.md measures it.
///
/// One step, on each rank:
///  0. the scene's extent and speeds, and the blocks' cuts moved towards each rank's measured
///     speed (Blocks::rebalance());
///  1. the halo: copies of its particles that could meet one of another rank's before their walls
///     (where a particle is when its path ends, widened by what any partner covers by then);
///  2. candidates: walls of the owned particles, pairs with an owned one (stage 06's grid);
///  3. the rounds of stage 03 across ranks (share_with_ghosts(), any_rank());
///  4. apply (a pair with a ghost: both owners compute it, each keeps its own particle);
///  5. migration: particles now in another rank's block move there (any rank, any distance), and
///     each rank keeps its own in the order of place (migrate()).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "plab/candidates.hpp"
#include "plab/close_lanes.hpp"
#include "plab/mpi/ranks.hpp"
#include "plab/sweep.hpp"
#include "exchange.hpp"
#include "search.hpp"

namespace plab::dist {

PairSearch gpu_search = nullptr;

namespace {

/// What the rounds exchange (shared_of()): only the ghosts that are a candidate partner of an
/// owned particle are ever read, so only their values travel. The counts are the same in every
/// round of a step, so each exchange is one MPI_Alltoallv, with no exchange of counts first.
struct Shared {
  std::vector<std::vector<int>> send;  //!< per rank q: the owned particles whose values q reads
  std::vector<int> recv;               //!< the ghosts read here, in the order their values come
  std::vector<int> recv_count;         //!< per rank q: how many of `recv` come from q
};

/// Sends, for every rank q, value[k] of each owned particle k in sh.send[q], and writes what
/// comes back into value[] of the ghosts in sh.recv.
template <class T>
void share_with_ghosts(const Ranks& r, const Shared& sh, std::vector<T>& value) {
  std::vector<std::vector<T>> out(r.ranks);
  for (int q = 0; q < r.ranks; ++q)
    for (int k : sh.send[q]) out[q].push_back(value[k]);
  const std::vector<T> in = all_to_all_known(r, out, sh.recv_count);
  for (std::size_t j = 0; j < in.size(); ++j) value[sh.recv[j]] = in[j];
}

/// What a ghost needs of its particle: its state and scene index, not its collision counts (a
/// pair with a ghost changes the ghost's copy, which the step drops): 40 bytes, not a Record's 56.
struct Ghost {
  double x, y, vx, vy;  //!< centre and velocity
  int id;               //!< its index in the scene
  int pad = 0;          //!< (keeps the struct a multiple of 8 bytes)
};

/// The engine's cut of the box: R ranks as a grid of px x py blocks (py the largest divisor of
/// R up to sqrt(R): 4 x 4 at 16 ranks, 4 x 2 at 8, 3 x 1 at 3), rank row * px + column. A
/// block's border is shorter than a slab's (at 16 ranks, 4 sides of L/4 against 2 of L), and so
/// is its halo. The cuts start even and move with the load (rebalance()): a column's cuts in x,
/// then each column's cuts in y. Not the kit's cut (Ranks::owner_of(), slabs): the kit's scatter
/// places the particles in the even blocks (first_owner()), and each step's migration keeps them
/// in their blocks; nothing needs them there at any time (the halo follows where each rank's
/// particles are, not where its block is), so any cuts give the same bits; every rank computes
/// the same cuts from the same numbers.
struct Blocks {
  int px = 1, py = 1;  //!< blocks across x and across y
  double L = 0;        //!< the box side
  int ranks = 0;       //!< R
  std::vector<double> xcut;               //!< px + 1 column cuts, 0 .. L
  std::vector<std::vector<double>> ycut;  //!< per column: py + 1 row cuts, 0 .. L

  /// Even cuts for `r` ranks in `box`, unless they are set for them already.
  void fit(const Ranks& r, const Box& box) { fit(r.ranks, box.L); }
  /// Even cuts for `count` ranks in a box of side `side`, unless they are set for them already.
  void fit(int count, double side) {
    if (ranks == count && L == side) return;
    ranks = count;
    L = side;
    py = 1;
    for (int d = 1; d * d <= ranks; ++d)
      if (ranks % d == 0) py = d;
    px = ranks / py;
    xcut = even(px);
    ycut.assign(px, even(py));
  }
  /// `parts` + 1 even cuts of [0, L].
  [[nodiscard]] std::vector<double> even(int parts) const {
    std::vector<double> cut(parts + 1);
    for (int k = 0; k <= parts; ++k) cut[k] = L * k / parts;
    return cut;
  }
  /// The part k of `cut` with cut[k] <= v < cut[k + 1] (below the first: 0; from the last: the
  /// last part; a not-a-number: 0).
  static int part(const std::vector<double>& cut, double v) {
    int k = 0;
    const int parts = static_cast<int>(cut.size()) - 1;
    while (k + 1 < parts && v >= cut[k + 1]) ++k;
    return k;
  }
  /// The rank that owns a particle whose centre is at (x, y).
  [[nodiscard]] int owner_of(double x, double y) const {
    const int column = part(xcut, x);
    return part(ycut[column], y) * px + column;
  }
  /// Moves the cuts halfway towards a share of the particles for each rank in proportion to its
  /// speed (`done[k]` particles searched in `seconds[k]` on rank k, the last step; a rank with
  /// neither counts at the mean speed). `owned[k]`: the particles rank k owns now, taken as spread
  /// evenly over its block (what the new cuts need of the particles' positions).
  void rebalance(const std::vector<double>& owned, const std::vector<double>& done,
                 const std::vector<double>& seconds);
};

/// The cut of [lo, hi] parts `cut` that leaves `share[0..k)` of `count`'s total below cut k,
/// `count[j]` spread evenly over part j; each cut moved halfway from where it is.
void move_cuts(std::vector<double>& cut, const std::vector<double>& count,
               const std::vector<double>& share) {
  const int parts = static_cast<int>(count.size());
  double total = 0, total_share = 0;
  for (int j = 0; j < parts; ++j) total += count[j], total_share += share[j];
  if (!(total > 0) || !(total_share > 0)) return;
  std::vector<double> next = cut;
  double want = 0, below = 0;
  int j = 0;
  for (int k = 1; k < parts; ++k) {
    want += total * share[k - 1] / total_share;
    while (j < parts - 1 && below + count[j] < want) below += count[j++];
    const double f = count[j] > 0 ? std::clamp((want - below) / count[j], 0.0, 1.0) : 0.0;
    const double target = cut[j] + f * (cut[j + 1] - cut[j]);
    next[k] = std::max(next[k - 1], cut[k] + 0.5 * (target - cut[k]));
  }
  cut = next;
}

void Blocks::rebalance(const std::vector<double>& owned, const std::vector<double>& done,
                       const std::vector<double>& seconds) {
  std::vector<double> speed(ranks, 0);
  double sum = 0;
  int known = 0;
  for (int k = 0; k < ranks; ++k)
    if (done[k] > 0 && seconds[k] > 0 && std::isfinite(done[k] / seconds[k])) {
      speed[k] = done[k] / seconds[k];
      sum += speed[k];
      ++known;
    }
  if (known == 0) return;
  for (int k = 0; k < ranks; ++k)
    if (speed[k] == 0) speed[k] = sum / known;
  std::vector<double> column_count(px, 0), column_speed(px, 0);
  for (int k = 0; k < ranks; ++k) {
    column_count[k % px] += owned[k];
    column_speed[k % px] += speed[k];
  }
  move_cuts(xcut, column_count, column_speed);
  for (int c = 0; c < px; ++c) {
    std::vector<double> count(py), share(py);
    for (int row = 0; row < py; ++row) {
      count[row] = owned[row * px + c];
      share[row] = speed[row * px + c];
    }
    move_cuts(ycut[c], count, share);
  }
}

/// The cuts of this process's run, kept from step to step (fit() sets them even for a new box or
/// rank count), and what this rank measured of its last step for rebalance().
struct Balance {
  Blocks blocks;
  double done = 0;     //!< particles this rank owned in its last step's search
  double seconds = 0;  //!< that search's time (find_candidates())
  bool on = !(std::getenv("PLAB_ENGINE_BALANCE") &&
              std::string(std::getenv("PLAB_ENGINE_BALANCE")) == "off");
};
Balance balance;

/// What every rank knows of the whole scene at the start of the step (the same on every rank).
struct Scene {
  double vx = 0;           //!< the largest |vx| of any particle (length per step)
  double vy = 0;           //!< the largest |vy| of any particle
  double margin = 0;       //!< the rounding margin m (sweep.hpp's, for the fastest speed)
  std::vector<double> lo;  //!< per rank: the least x of its owned particles (+inf: none)
  std::vector<double> hi;  //!< per rank: the greatest x of its owned particles
  std::vector<double> ylo;  //!< per rank: the least y of its owned particles (+inf: none)
  std::vector<double> yhi;  //!< per rank: the greatest y of its owned particles
  std::vector<double> owned;    //!< per rank: the particles it owns
  std::vector<double> done;     //!< per rank: the particles it owned in its last step's search
  std::vector<double> seconds;  //!< per rank: that search's time (Balance)
  double n = 0;            //!< particles in the scene
};

/// The Scene, from every rank's owned particles (three reductions and one exchange).
Scene scene_of(const Ranks& r, const Box& box, const Local& s) {
  Scene sc;
  double v2 = 0, lo = HUGE_VAL, hi = -HUGE_VAL, ylo = HUGE_VAL, yhi = -HUGE_VAL;
  for (int k = 0; k < s.owned; ++k) {
    sc.vx = std::fmax(sc.vx, std::fabs(s.p.vx[k]));
    sc.vy = std::fmax(sc.vy, std::fabs(s.p.vy[k]));
    v2 = std::fmax(v2, s.p.vx[k] * s.p.vx[k] + s.p.vy[k] * s.p.vy[k]);
    lo = std::fmin(lo, s.p.x[k]);
    hi = std::fmax(hi, s.p.x[k]);
    ylo = std::fmin(ylo, s.p.y[k]);
    yhi = std::fmax(yhi, s.p.y[k]);
  }
  sc.vx = max_over_ranks(r, sc.vx);
  sc.vy = max_over_ranks(r, sc.vy);
  sc.margin = 1e-6 * (box.L + std::sqrt(max_over_ranks(r, v2)) + box.r);
  const std::vector<std::vector<double>> mine(
      r.ranks,
      std::vector<double>{lo, hi, ylo, yhi, 1.0 * s.owned, balance.done, balance.seconds});
  const std::vector<double> all = all_to_all(r, mine);
  for (int q = 0; q < r.ranks; ++q) {
    const double* at = &all[7 * q];
    sc.lo.push_back(at[0]);
    sc.hi.push_back(at[1]);
    sc.ylo.push_back(at[2]);
    sc.yhi.push_back(at[3]);
    sc.owned.push_back(at[4]);
    sc.done.push_back(at[5]);
    sc.seconds.push_back(at[6]);
    sc.n += at[4];
  }
  return sc;
}

/// When particle k's path stops mattering for pairs: its wall time if that is in the step, else
/// 1 (sweep::path_end(): a pair at or after a particle's wall time is never accepted).
double end_of(const Box& box, const Local& s, int k) {
  return sweep::path_end(model::wall_time(s.p.x[k], s.p.y[k], s.p.vx[k], s.p.vy[k], box.L, box.r));
}

/// 1. The halo: copies of every particle that could meet one of a rank's own before both their
/// walls in this step. Owned particle k whose path ends at T = end_of(k) (T <= 0: it meets
/// nobody) is at x_k + t vx_k at time t <= T; a partner of rank q is then within sc.vx t of
/// [sc.lo[q], sc.hi[q]]. That range grows at least as fast as k moves (sc.vx >= |vx_k|), so if
/// they can meet at some t <= T, k is also within reach of it at T: k can meet one of q's only
/// if [x_k + T vx_k -+ (T sc.vx + 2r + 2m)] meets [sc.lo[q], sc.hi[q]] (handout 08 proves it),
/// and, by the same argument in y, [y_k + T vy_k -+ (T sc.vy + 2r + 2m)] meets
/// [sc.ylo[q], sc.yhi[q]]: k goes to q when both do (a not-a-number sends it everywhere).
void share_halo(const Ranks& r, const Box& box, const Scene& sc, Local& s) {
  s.sent_to.assign(r.ranks, {});
  std::vector<std::vector<Ghost>> out(r.ranks);
  for (int k = 0; k < s.owned && r.ranks > 1; ++k) {  // (a rank alone has no halo)
    const double T = end_of(box, s, k);
    if (!(T > 0)) continue;  // its wall comes first: it takes part in no pair
    const double at = s.p.x[k] + T * s.p.vx[k], yat = s.p.y[k] + T * s.p.vy[k];
    const double cover = (T * sc.vx + 2 * box.r + 2 * sc.margin) * (1 + 1e-9);
    const double ycover = (T * sc.vy + 2 * box.r + 2 * sc.margin) * (1 + 1e-9);
    const double lo = at - cover, hi = at + cover, ylo = yat - ycover, yhi = yat + ycover;
    for (int q = 0; q < r.ranks; ++q)
      if (q != r.rank && !(hi < sc.lo[q]) && !(lo > sc.hi[q]) && !(yhi < sc.ylo[q]) &&
          !(ylo > sc.yhi[q])) {
        s.sent_to[q].push_back(k);
        out[q].push_back(Ghost{s.p.x[k], s.p.y[k], s.p.vx[k], s.p.vy[k], s.id[k]});
      }
  }
  for (const Ghost& g : all_to_all(r, out, &s.ghosts_from))
    s.push(Record{g.x, g.y, g.vx, g.vy, 0, 0, g.id});
  for (int& start : s.ghosts_from) start += s.owned;
}

constexpr double kAlpha = 0.2;  //!< time slabs per sqrt(density) v_cut: stage 06's engine's (engine.md)

/// The space-time grid of stage 06 (sweep::choose(): reach, margin, v_cut) fitted to the
/// rectangle that the paths here cover, [x0, x0 + w) x [y0, y0 + h), instead of the whole box: a
/// rank's particles lie in a slab and its halo. The time slabs are those stage 06 chooses for the
/// whole scene, \f$K = \lceil \alpha \sqrt N\, v_{cut} / L \rceil\f$ with its \f$\alpha =
/// 0.2\f$ (they follow the density, \f$\sqrt{N / L^2}\f$, which a rank shares with the scene,
/// not its own count of particles), with this rank's \f$v_{cut}\f$. Cells are at least a slow
/// particle's reach, about 4n of them.
LocalGrid fit_grid(const Box& box, const Scene& sc, const Particles& p,
                   const std::vector<double>& end, std::vector<double>& scratch) {
  LocalGrid lg{sweep::choose(box, p, end, scratch, 0.9, kAlpha)};
  sweep::Grid& g = lg.g;
  if (!std::isfinite(g.cell)) return lg;  // no geometry to trust: one cell
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  int active = 0;
  for (int i = 0; i < static_cast<int>(p.size()); ++i) {
    if (!(end[i] > 0)) continue;
    ++active;
    const double xe = p.x[i] + end[i] * p.vx[i], ye = p.y[i] + end[i] * p.vy[i];
    x0 = std::fmin(x0, std::fmin(p.x[i], xe)), x1 = std::fmax(x1, std::fmax(p.x[i], xe));
    y0 = std::fmin(y0, std::fmin(p.y[i], ye)), y1 = std::fmax(y1, std::fmax(p.y[i], ye));
  }
  if (active == 0 || !std::isfinite(x1 - x0) || !std::isfinite(y1 - y0)) return lg;
  const double w = x1 - x0, h = y1 - y0;
  g.slabs = static_cast<int>(
      std::clamp(std::ceil(kAlpha * std::sqrt(std::fmax(sc.n, 1.0)) * g.v_cut / box.L), 1.0, 256.0));
  g.half = 0.5 / g.slabs;
  const double wanted = (g.reach + 2 * g.margin + 2 * g.half * g.v_cut) * (1 + 1e-9);
  double cell = std::fmax(wanted, std::sqrt(sweep::kColumnsPerCell * w * h / (4.0 * active)));
  const auto count = [&](double extent, double per) { return std::floor(extent * per / cell) + 1; };
  while (count(h, 1) * count(w, sweep::kColumnsPerCell) > 8.0 * active + 64) cell *= 2;
  g.cell = cell;
  g.inv_cell = 1 / cell;
  g.inv_column = sweep::kColumnsPerCell / cell;
  g.rows = static_cast<int>(count(h, 1));
  g.columns = static_cast<int>(count(w, sweep::kColumnsPerCell));
  lg.x0 = x0;
  lg.y0 = y0;
  return lg;
}

/// One time slab's entries, in cell order: the particles that take part, by the cell of their
/// midpoint positions (shifted by the grid's origin, rounded to float: the entry's cell is the
/// rounded midpoint's, as in stage 06's engine), the owned ones first in each cell.
struct Entries {
  std::vector<int> start;            //!< cell c holds entries [start[c], start[c + 1])
  std::vector<int> owned_end;        //!< cell c's owned entries are [start[c], owned_end[c])
  std::vector<int> cell;             //!< per particle: its cell in this slab
  std::vector<int> id;               //!< per entry: the particle (local index)
  std::vector<float> x, y, vx, vy;   //!< per entry: shifted midpoint position, velocity, rounded
                                     //!< to float (padded by lanes::kLanesSingle for the loads)
  std::vector<sweep::PackedSearch> reach;  //!< per entry: what it searches (sweep::search_of())
  int owned_from = 0;                //!< the first column that holds an owned entry
  int owned_to = -1;                 //!< the last one (owned_to < owned_from: none)
};

/// Slab k's counting sort of the particles that take part in it (first[i] <= k <= last[i]).
void bin(Entries& e, const Particles& p, int owned, const std::vector<int>& first,
         const std::vector<int>& last, const std::vector<sweep::PackedSearch>& reach, int k,
         const LocalGrid& lg) {
  const sweep::Grid& g = lg.g;
  const int n = static_cast<int>(p.size());
  const double tm = sweep::slab_mid(k, g);
  e.start.assign(g.cells() + 1, 0);
  e.owned_end.assign(g.cells(), 0);
  e.cell.resize(n);
  int m = 0;
  for (int i = 0; i < n; ++i) {
    if (last[i] < k || first[i] > k) continue;
    e.cell[i] = sweep::cell_of(sweep::rounded_midpoint(p.x[i], p.vx[i], tm, lg.x0),
                               sweep::rounded_midpoint(p.y[i], p.vy[i], tm, lg.y0), g);
    ++e.start[e.cell[i] + 1];
    if (i < owned) ++e.owned_end[e.cell[i]];
    ++m;
  }
  for (int c = 0; c < g.cells(); ++c) e.start[c + 1] += e.start[c];
  for (auto* v : {&e.x, &e.y, &e.vx, &e.vy}) v->resize(m + lanes::kLanesSingle);
  e.id.resize(m);
  e.reach.resize(m);
  e.owned_from = g.columns;
  e.owned_to = -1;
  for (int i = 0; i < n; ++i) {  // start[c] moves on to where cell c + 1 starts (owned first:
                                 // they are particles 0 .. owned - 1)
    if (last[i] < k || first[i] > k) continue;
    const int at = e.start[e.cell[i]]++;
    e.id[at] = i;
    e.reach[at] = reach[i];
    e.x[at] = sweep::rounded_midpoint(p.x[i], p.vx[i], tm, lg.x0);
    e.y[at] = sweep::rounded_midpoint(p.y[i], p.vy[i], tm, lg.y0);
    e.vx[at] = static_cast<float>(p.vx[i]);
    e.vy[at] = static_cast<float>(p.vy[i]);
    if (i < owned) {
      const int column = e.cell[i] % g.columns;
      e.owned_from = std::min(e.owned_from, column);
      e.owned_to = std::max(e.owned_to, column);
    }
  }
  for (int c = g.cells(); c > 0; --c) e.start[c] = e.start[c - 1];
  e.start[0] = 0;
  for (int c = 0; c < g.cells(); ++c) e.owned_end[c] += e.start[c];
}

/// What a slab's search needs besides its entries: the grid, the single-precision test's
/// constants (sweep::single_of(): a superset of the pairs sweep::close_in_slab() passes on the
/// unrounded values, as in stage 06's engine), and where the pairs that pass go.
struct SearchOf {
  const sweep::Grid& g;                     //!< the grid (rows, columns)
  const sweep::Single& single;              //!< the test's constants
  std::vector<std::pair<int, int>>& hits;  //!< pairs of particles (local indices) that passed
};

/// Files entry `a` with every entry of [from, to) (but itself) that passes
/// sweep::close_in_slab_single() (lanes::for_each_close_single(), with kIsa's vectors).
template <lanes::Isa kIsa>
void test_range(const Entries& e, int a, int from, int to, SearchOf& to_file) {
  lanes::for_each_close_single<kIsa>({e.x.data(), e.y.data(), e.vx.data(), e.vy.data()}, a, from,
                                     to, to_file.single, [&](int b) {
                                       if (b != a) to_file.hits.emplace_back(e.id[a], e.id[b]);
                                     });
}

/// Slab k's search (stage 06's, sweep::search_of()): a slow entry against the later entries of
/// its row up to the last column within its reach, then the columns within reach of the next row;
/// a fast entry against every entry within its reach, one run per row. A ghost tests only the
/// owned entries of those cells (first in each cell), in the columns that hold any: pairs of two
/// ghosts no rank needs, and an owned entry before a ghost in its cell finds it itself.
template <lanes::Isa kIsa>
void search_cells(const Entries& e, int owned, SearchOf& to_file) {
  const sweep::Grid& g = to_file.g;
  const int columns = g.columns;
  for (int row = 0, a = 0; row < g.rows; ++row) {
    for (const int end = e.start[(row + 1) * columns]; a < end; ++a) {
      const sweep::PackedSearch q = e.reach[a];
      const double d = q.d();
      int x0, x1;
      sweep::columns_within(e.x[a], d, g, x0, x1);
      if (e.id[a] >= owned) {  // a ghost
        x0 = std::max(x0, e.owned_from);
        x1 = std::min(x1, e.owned_to);
        int y0 = row, y1 = std::min(row + 1, g.rows - 1);
        if (q.fast()) sweep::rows_within(e.y[a], d, g, y0, y1);
        const int own = e.cell[e.id[a]] % columns;
        for (int y = y0; y <= y1; ++y)
          for (int c = (!q.fast() && y == row) ? std::max(x0, own + 1) : x0; c <= x1; ++c)
            test_range<kIsa>(e, a, e.start[y * columns + c], e.owned_end[y * columns + c], to_file);
        continue;
      }
      if (!q.fast()) {
        test_range<kIsa>(e, a, a + 1, e.start[row * columns + x1 + 1], to_file);
        if (row + 1 < g.rows)
          test_range<kIsa>(e, a, e.start[(row + 1) * columns + x0],
                           e.start[(row + 1) * columns + x1 + 1], to_file);
      } else {  // a pair found twice is harmless
        int y0, y1;
        sweep::rows_within(e.y[a], d, g, y0, y1);
        for (int y = y0; y <= y1; ++y)
          test_range<kIsa>(e, a, e.start[y * columns + x0], e.start[y * columns + x1 + 1], to_file);
      }
    }
  }
}

#if PLAB_AVX2
/// search_cells() with AVX-512.
__attribute__((target("avx512f"), flatten)) void search_avx512(const Entries& e, int owned,
                                                                SearchOf& to_file) {
  search_cells<lanes::Isa::kAvx512>(e, owned, to_file);
}

/// search_cells() with AVX2 (the single-precision test's portable loop, which the compiler may
/// vectorise for it).
__attribute__((target("avx2"), flatten)) void search_avx2(const Entries& e, int owned,
                                                          SearchOf& to_file) {
  search_cells<lanes::Isa::kAvx2>(e, owned, to_file);
}
#endif

/// The vectors of the pair test on this rank: the widest the CPU has, or narrower ones when the
/// run asks (StageOptions::simd, PLAB_SIMD on the other ranks). Set before the first step.
lanes::Isa isa_in_use = lanes::Isa::kPortable;

/// Slab k's search with the chosen vectors (search_cells()).
void search(const Entries& e, int owned, SearchOf& to_file) {
#if PLAB_AVX2
  if (isa_in_use == lanes::Isa::kAvx512) return search_avx512(e, owned, to_file);
  if (isa_in_use == lanes::Isa::kAvx2) return search_avx2(e, owned, to_file);
#endif
  search_cells<lanes::Isa::kPortable>(e, owned, to_file);
}

/// When the gap between a ghost at `x` moving at `v` and the range [lo, hi] that grows at `speed`
/// on each side, less `c` = 2r + 2m, can have closed, along one axis: it closes at v + speed
/// from the left (speed - v from the right); 0 when the ghost is within reach already (or
/// unsure).
double gap_closes(double x, double v, double lo, double hi, double speed, double c) {
  const double left = (lo - c) - x, right = x - (hi + c);
  if (left > 0) return left / (v + speed);
  if (right > 0) return right / (speed - v);
  return 0;
}

/// The first time slab in which a ghost at (x, y) moving at (vx, vy) can meet a particle of rank
/// q: q's particles are within sc.vx t of [sc.lo[q], sc.hi[q]] in x and within sc.vy t of
/// [sc.ylo[q], sc.yhi[q]] in y at time t, and the ghost can meet one only once both gaps have
/// closed (gap_closes()). Slabs before that time need not hold the ghost. (0 when unsure.)
int first_slab(const Box& box, const Scene& sc, int q, double x, double y, double vx, double vy,
               const sweep::Grid& g) {
  const double c = 2 * box.r + 2 * sc.margin;
  const double tx = gap_closes(x, vx, sc.lo[q], sc.hi[q], sc.vx, c);
  const double ty = gap_closes(y, vy, sc.ylo[q], sc.yhi[q], sc.vy, c);
  if (tx != tx || ty != ty) return 0;  // a not-a-number: unsure
  const double t = (tx > ty ? tx : ty) * (1 - 1e-9);
  if (!(t > 0)) return 0;
  return t >= 1 ? g.slabs : static_cast<int>(std::fmin(std::floor(t * g.slabs), g.slabs));
}

/// 2. The candidates of the owned particles: their walls, and their pairs with any particle
/// here (each pair time computed with the lower scene index first, as every stage does), found
/// by stage 06's space-time grid over the owned particles and the ghosts (sweep.hpp): every pair
/// that can meet in the step before both walls is found, and few others.
void find_candidates(const Box& box, const Ranks& r, const Scene& sc, const Local& s,
                     std::vector<double>& wall, CandidateLists& cand) {
  const Particles& p = s.p;
  const int n = s.size();
  std::vector<double> end(n), scratch;
  wall.assign(n, model::never());
  for (int i = 0; i < n; ++i) {
    wall[i] = model::wall_time(p.x[i], p.y[i], p.vx[i], p.vy[i], box.L, box.r);
    end[i] = sweep::path_end(wall[i]);
  }
  const LocalGrid lg = fit_grid(box, sc, p, end, scratch);
  std::vector<int> first(n, 0), last(n);
  std::vector<sweep::PackedSearch> reach(n);
  for (int i = 0; i < n; ++i) {
    last[i] = sweep::last_slab(end[i], lg.g);
    reach[i] = sweep::PackedSearch::of(sweep::search_of(p.vx[i], p.vy[i], lg.g));
    if (i >= s.owned)
      first[i] = first_slab(box, sc, r.rank, p.x[i], p.y[i], p.vx[i], p.vy[i], lg.g);
  }
  std::vector<std::vector<FoundPair>> found(1);
  if (r.gpu) {  // the same search and narrow phase on this rank's GPU (step.cu)
    if (gpu_search == nullptr) throw NoDevice("stage 08 was built without its GPU path");
    gpu_search(box, r, lg, s, first, last, found[0]);
    cand.build(n, found);
    return;
  }
  Entries e;
  std::vector<std::pair<int, int>> hits;
  // Every speed is at most the largest |vx| and |vy| of the scene's particles together.
  const sweep::Single single =
      sweep::single_of(lg.g, box.L, std::hypot(sc.vx, sc.vy) * (1 + 1e-6));
  SearchOf to_file{lg.g, single, hits};
  for (int k = 0; k < lg.g.slabs; ++k) {
    bin(e, p, s.owned, first, last, reach, k, lg);
    search(e, s.owned, to_file);
  }
  for (auto& [a, b] : hits)
    if (a > b) std::swap(a, b);
  std::sort(hits.begin(), hits.end());
  hits.erase(std::unique(hits.begin(), hits.end()), hits.end());
  for (const auto& [i, j] : hits) {  // the narrow phase
    const bool ij = s.id[i] < s.id[j];
    const int a = ij ? i : j, b = ij ? j : i;
    const double t =
        model::pair_time(p.x[a], p.y[a], p.vx[a], p.vy[a], p.x[b], p.y[b], p.vx[b], p.vy[b], box.r);
    if (model::in_step(t)) found[0].push_back(FoundPair{t, i, j});
  }
  cand.build(n, found);
}

/// Which ghosts' values the rounds need here (the candidate partners of the owned particles),
/// and, from what the other ranks say they need, which owned particles' values go where (one
/// exchange a step).
Shared shared_of(const Ranks& r, const Local& s, const CandidateLists& cand) {
  std::vector<char> read(s.size(), 0);
  for (int i = 0; i < s.owned; ++i)
    for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) read[cand.other[k]] = 1;
  Shared sh;
  sh.recv_count.assign(r.ranks, 0);
  std::vector<std::vector<int>> ask(r.ranks);  // positions in the owner's list s.sent_to[q]
  for (int q = 0; q < r.ranks; ++q)
    for (int g = s.ghosts_from[q]; g < s.ghosts_from[q + 1]; ++g)
      if (read[g]) {
        ask[q].push_back(g - s.ghosts_from[q]);
        sh.recv.push_back(g);
        ++sh.recv_count[q];
      }
  std::vector<int> from;
  const std::vector<int> asked = all_to_all(r, ask, &from);
  sh.send.assign(r.ranks, {});
  for (int q = 0; q < r.ranks; ++q)
    for (int j = from[q]; j < from[q + 1]; ++j) sh.send[q].push_back(s.sent_to[q][asked[j]]);
  return sh;
}

/// 3. Stage 03's rounds across ranks. Returns each owned particle's event (walls and pairs
/// keyed by scene indices; `t` = never for none), the same as model.md's greedy over every rank.
std::vector<model::Event> choose_events(const Ranks& r, const Local& s, const Shared& sh,
                                        const std::vector<double>& wall,
                                        const CandidateLists& cand) {
  const int n = s.size();
  const model::Event none = model::pair_event_key(model::never(), -1, -1);
  std::vector<char> resolved(n, 0);
  std::vector<model::Event> best(n, none), chosen(s.owned, none);
  for (bool open = true; open;) {
    share_with_ghosts(r, sh, resolved);  // whom the ghosts' owners resolved last round
    for (int i = 0; i < s.owned; ++i) {
      if (resolved[i]) continue;
      model::Event b = model::in_step(wall[i]) ? model::wall_event_key(wall[i], s.id[i]) : none;
      for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) {
        const int o = cand.other[k];
        if (resolved[o]) continue;
        const int lo = std::min(s.id[i], s.id[o]), hi = std::max(s.id[i], s.id[o]);
        const model::Event e = model::pair_event_key(cand.time[k], lo, hi);
        if (model::key_less(e, b)) b = e;
      }
      best[i] = b;
    }
    share_with_ghosts(r, sh, best);  // what the ghosts chose
    bool left = false;
    for (int i = 0; i < s.owned; ++i) {
      if (resolved[i]) continue;
      const model::Event& e = best[i];
      bool mutual = false;
      if (model::in_step(e.t) && e.kind == model::kPair)
        for (int k = cand.start[i]; k < cand.start[i + 1]; ++k) {
          const model::Event& o = best[cand.other[k]];
          if (o.kind == model::kPair && o.lo == e.lo && o.hi == e.hi && o.t == e.t) mutual = true;
        }
      if (!model::in_step(e.t) || e.kind == model::kWall || mutual) {
        chosen[i] = e;
        resolved[i] = 1;
      } else {
        left = true;
      }
    }
    open = any_rank(r, left);
  }
  return chosen;
}

/// 4. Applies each owned particle's event. A pair with a ghost is computed here too, on the
/// ghost's copy, in the same order as its owner computes it: both keep the same bits.
void apply_events(const Box& box, const std::vector<model::Event>& chosen,
                  const CandidateLists& cand, Local& s) {
  Particles& p = s.p;
  for (int i = 0; i < s.owned; ++i) {
    const model::Event& e = chosen[i];
    if (!model::in_step(e.t)) {
      model::free_move(p.x[i], p.y[i], p.vx[i], p.vy[i]);
    } else if (e.kind == model::kWall) {
      model::wall_event(p.x[i], p.y[i], p.vx[i], p.vy[i], p.wc[i], box.L, box.r);
    } else {
      const int other_id = e.lo == s.id[i] ? e.hi : e.lo;
      int o = -1;
      for (int k = cand.start[i]; k < cand.start[i + 1] && o < 0; ++k)
        if (s.id[cand.other[k]] == other_id) o = cand.other[k];
      if (o < s.owned && s.id[o] < s.id[i]) continue;  // an owned pair: applied from its lower
      const int a = s.id[i] < s.id[o] ? i : o, b = a == i ? o : i;
      model::pair_event(p.x[a], p.y[a], p.vx[a], p.vy[a], p.pc[a], p.x[b], p.y[b], p.vx[b],
                        p.vy[b], p.pc[b], e.t, box.L, box.r);
    }
  }
}

/// 5. Migration: every owned particle now in another rank's block goes there (`blocks`); ghosts
/// are dropped. What a rank keeps (those that stay, then those that came) goes into the order of
/// a coarse grid over their range (rows in y, then columns in x, about four particles a cell: a
/// counting sort into a second set of arrays, kept from step to step, which then takes the place
/// of `s`'s): nearly the order of the next step's cells, so that each time slab's counting sort
/// (bin()) reads the particles in about the order it writes them and the search's neighbours lie
/// close together in memory. No bit depends on the order: events are keyed by scene indices, and
/// a pair's time is computed with the lower one first.
void migrate(const Ranks& r, const Blocks& blocks, Local& s) {
  std::vector<std::vector<Record>> out(r.ranks);
  std::vector<int> stay;  // owned particles that stay here
  stay.reserve(s.owned);
  for (int k = 0; k < s.owned; ++k) {
    const int q = blocks.owner_of(s.p.x[k], s.p.y[k]);
    if (q == r.rank) stay.push_back(k);
    else out[q].push_back(s.record(k));
  }
  const std::vector<Record> came = all_to_all(r, out);
  const int m = static_cast<int>(stay.size()), n = m + static_cast<int>(came.size());
  const auto x_of = [&](int j) { return j < m ? s.p.x[stay[j]] : came[j - m].x; };
  const auto y_of = [&](int j) { return j < m ? s.p.y[stay[j]] : came[j - m].y; };
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  for (int j = 0; j < n; ++j) {
    x0 = std::fmin(x0, x_of(j)), x1 = std::fmax(x1, x_of(j));
    y0 = std::fmin(y0, y_of(j)), y1 = std::fmax(y1, y_of(j));
  }
  // One cell (the order they are in) when the range gives no grid.
  const bool grid = n >= 2 && x1 - x0 > 0 && y1 - y0 > 0 && std::isfinite(x1 - x0) &&
                    std::isfinite(y1 - y0);
  const int side = grid ? std::max(1, static_cast<int>(std::sqrt(n / 4.0))) : 1;
  const double fx = grid ? side / (x1 - x0) : 0, fy = grid ? side / (y1 - y0) : 0;
  const auto index = [side](double v) {  // 0 .. side - 1; a not-a-number: 0
    return v >= 0 ? (v < side ? static_cast<int>(v) : side - 1) : 0;
  };
  std::vector<int> start(static_cast<std::size_t>(side) * side + 1, 0), cell(n);
  for (int j = 0; j < n; ++j) {
    cell[j] = grid ? index((y_of(j) - y0) * fy) * side + index((x_of(j) - x0) * fx) : 0;
    ++start[cell[j] + 1];
  }
  for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  static Local kept;  // (one rank a process)
  kept.p.resize(n);
  kept.id.resize(n);
  for (int j = 0; j < n; ++j) {
    const int at = start[cell[j]]++;
    const Record q = j < m ? s.record(stay[j]) : came[j - m];
    kept.p.x[at] = q.x, kept.p.y[at] = q.y, kept.p.vx[at] = q.vx, kept.p.vy[at] = q.vy;
    kept.p.pc[at] = q.pc, kept.p.wc[at] = q.wc, kept.id[at] = q.id;
  }
  kept.owned = n;
  kept.sent_to.clear();
  kept.ghosts_from.clear();
  std::swap(s, kept);
}

}  // namespace

/// The kit's scatter's owner (search.hpp): the block of the even cuts that step() starts from.
int first_owner(double x, double y, double L, int ranks) {
  static Blocks even;  // (rank 0's scatter only)
  even.fit(ranks, L);
  return even.owner_of(x, y);
}

/// Where a rank's time goes, part by part (PLAB_ENGINE_PHASES=1 asks for it): MPI_Wtime() laps
/// of step()'s parts, summed over the steps, and the particles it held. Each rank writes one line
/// to stderr when its process ends (handouts/engine-08.md reads them). An exchange's time
/// includes the wait for the slowest rank: `shared` is the first exchange after the search, so
/// it holds most of the search's imbalance.
struct PhaseClock {
  static constexpr int kParts = 7;
  static constexpr const char* kNames[kParts] = {"scene",  "halo",  "search", "shared",
                                                 "rounds", "apply", "migrate"};
  double seconds[kParts] = {};
  double owned = 0, ghosts = 0;  //!< summed over the steps
  long long steps = 0;
  int rank = -1;
  bool on = std::getenv("PLAB_ENGINE_PHASES") != nullptr;
  ~PhaseClock() {
    if (!on || steps == 0) return;
    std::string line = "stage 08 (engine) rank " + std::to_string(rank) + ", ms a step:";
    char part[64];
    for (int k = 0; k < kParts; ++k) {
      std::snprintf(part, sizeof part, " %s %.1f", kNames[k], 1e3 * seconds[k] / steps);
      line += part;
    }
    std::snprintf(part, sizeof part, "; %.0f owned, %.0f ghosts\n", owned / steps, ghosts / steps);
    std::fputs((line + part).c_str(), stderr);
  }
};
PhaseClock phases;

/// One step on this rank: the five parts above, in order.
void step(const Box& box, const Ranks& r, Local& s) {
  double t0 = phases.on ? MPI_Wtime() : 0;
  const auto lap = [&](int part) {
    if (!phases.on) return;
    const double t1 = MPI_Wtime();
    phases.seconds[part] += t1 - t0;
    t0 = t1;
  };
  const Scene sc = scene_of(r, box, s);
  balance.blocks.fit(r, box);
  if (balance.on) balance.blocks.rebalance(sc.owned, sc.done, sc.seconds);
  lap(0);
  share_halo(r, box, sc, s);
  lap(1);
  std::vector<double> wall;
  CandidateLists cand;
  const double search_from = MPI_Wtime();
  find_candidates(box, r, sc, s, wall, cand);
  balance.done = s.owned;
  balance.seconds = MPI_Wtime() - search_from;
  lap(2);
  const Shared sh = shared_of(r, s, cand);
  lap(3);
  const std::vector<model::Event> chosen = choose_events(r, s, sh, wall, cand);
  lap(4);
  apply_events(box, chosen, cand, s);
  lap(5);
  phases.owned += s.owned;
  phases.ghosts += s.size() - s.owned;
  phases.rank = r.rank;
  ++phases.steps;
  migrate(r, balance.blocks, s);
  lap(6);
}

}  // namespace plab::dist

namespace plab {

/// Stage 08's first call on every rank (stage.hpp): the kit's MPI driver (plab/mpi/ranks.hpp)
/// serves rank 0's run with this stage's step on every other rank. make_gpu_stepper() with
/// the CPU asked for only sets dist::gpu_search (where this build has a GPU path), so that these
/// ranks can step on the GPU when rank 0's run does.
int stage_worker() {
  Particles none;
  StageOptions cpu;
  cpu.device = Device::kCpu;
  make_gpu_stepper(Box{}, none, cpu);
  dist::isa_in_use = lanes::choose_isa(StageOptions::from_environment().simd);
  return dist::serve(dist::step);
}

/// Stage 08's entry point (stage.hpp), on rank 0: the kit's MPI driver with this stage's step,
/// on the CPU, or on one GPU per rank with `--device gpu` (make_gpu_stepper(), step.cu; NoDevice
/// where there is none). `--device auto` is the CPU here: the GPU is asked for, not taken, since
/// several ranks of one machine would share its GPUs.
std::unique_ptr<Stepper> make_stepper(const Box& box, Particles& p, const StageOptions& options) {
  dist::isa_in_use = lanes::choose_isa(options.simd);
  if (auto gpu = make_gpu_stepper(box, p, options)) return gpu;
  return dist::mpi_stage_any_cut(box, p, dist::step, "", dist::first_owner);  // blocks, not slabs
}

}  // namespace plab
