#pragma once
// The solver's private state: the cell grid, neighbour blocks, pair lists and per-thread accumulators
// (Solver<D>::Impl), shared by the solver's translation units (engine/src/solver/*.cpp).
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "runout/engine/eos.hpp"
#include "runout/engine/solver.hpp"
#include "pass_context.hpp"

namespace runout {
namespace solver_detail {

constexpr int kCellBits = 21;
constexpr int64_t kCellBias = int64_t{1} << (kCellBits - 1);
constexpr uint64_t kRemovedKey = std::numeric_limits<uint64_t>::max();

inline std::string fmt_time(real t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "t=%.6g s", t);
  return buf;
}

// The largest values an evaluation sees, for the time step: |a|^2, the artificial-viscosity term mu_ij and the
// kinematic viscosity. Each thread keeps its own and they are merged at the end of a pass.
struct PassMaxima {
  real acc2 = 0, visc_term = 0, nu = 0;
  void merge(const PassMaxima& o) {
    acc2 = std::max(acc2, o.acc2);
    visc_term = std::max(visc_term, o.visc_term);
    nu = std::max(nu, o.nu);
  }
};

// Cell grid and neighbour blocks. Cells have size h (half the kernel support) and are searched two cells
// each way. Keys pack the vertical axis in the lowest bits, so the five cells of one vertical column are
// contiguous in sorted order: each neighbour "block" is one such column run (5 blocks per cell in 2D, 25 in
// 3D) plus the periodic image shift to apply to it. The fluid's cells are rebuilt at every sort (cells.cpp),
// the walls' when the walls alive change (wall_tiles.cpp); the wall cells next to fluid are the active ones.
template <int D>
struct CellIndex {
  struct Block {
    uint32_t begin, end, shift;
    uint32_t cell0, cell1;  // the cells (indices into the key array) the run covers
  };
  static constexpr int kReach = 2;
  static constexpr int kSpan = 2 * kReach + 1;
  static constexpr int kNb = D == 2 ? kSpan : kSpan * kSpan;
  // Half stencil of fluid columns (the own column first, then those after it: each pair once), stride kHalf.
  static constexpr int kHalf = kNb / 2 + 1;

  Vec<D> origin, cell_size, inv_cell, period;
  std::array<int64_t, D> periodic_cells{};  // 0 if the axis is not periodic
  std::vector<Vec<D>> shifts;                // 3^(D-1) entries, index sum (s_d + 1) 3^d over horizontal axes

  // Fluid cells (keys, and where each starts in the sorted fluid; size cells + 1) and their neighbour blocks.
  std::vector<uint64_t> fcell_key;
  std::vector<uint32_t> fcell_begin;
  std::vector<Block> fnb_half;   // fluid columns, stride kHalf per fluid cell
  std::vector<uint8_t> fnb_half_n;
  std::vector<Block> fnb_bound;  // boundary columns, stride kNb per fluid cell
  std::vector<uint8_t> fnb_bound_n;
  std::vector<std::pair<uint64_t, uint32_t>> sort_buf;  // the fluid sort's (key, index)

  // Wall cells, and those next to fluid (active: stamped with the current stamp).
  std::vector<uint64_t> bcell_key;
  std::vector<uint32_t> bcell_begin;
  std::vector<uint32_t> bcell_stamp;
  uint32_t stamp = 0;
  std::vector<uint32_t> active_bcells;
  // Active boundary particles (those in active cells) numbered 0.. in active-cell order: bslot[b] is valid
  // for them only. Per-thread boundary accumulators are this long, not the whole boundary's length.
  std::vector<uint32_t> bslot;
  size_t active_boundary_count = 0;

  // The fluid particles, cell by cell, shared among the threads of the enclosing parallel region. A static
  // schedule (chunks of 16 cells dealt round-robin): the same cells go to the same thread every step, so the
  // per-thread accumulators (Solver::Impl::accumulate) hold the same partial sums and a run repeats to the bit
  // at a given thread count; with a dynamic schedule it did not.
  template <class F>
  void for_each_fluid(F&& f) const {
    const size_t ncells = fcell_key.size();
#pragma omp for schedule(static, 16)
    for (size_t c = 0; c < ncells; ++c)
      for (uint32_t i = fcell_begin[c]; i < fcell_begin[c + 1]; ++i) f(i);
  }
  // f(b) for every active wall particle, as a parallel loop of its own.
  template <class F>
  void for_each_active_wall(F&& f) const {
    const size_t nact = active_bcells.size();
#pragma omp parallel for schedule(static)
    for (size_t a = 0; a < nact; ++a) {
      const uint32_t cb = active_bcells[a];
      for (uint32_t b = bcell_begin[cb]; b < bcell_begin[cb + 1]; ++b) f(b);
    }
  }

  std::array<int64_t, D> coords(const Vec<D>& p) const {
    std::array<int64_t, D> c;
    for (int d = 0; d < D; ++d) {
      int64_t k = static_cast<int64_t>(std::floor((p[d] - origin[d]) * inv_cell[d]));
      if (periodic_cells[d] > 0) {
        k %= periodic_cells[d];
        if (k < 0) k += periodic_cells[d];
      }
      c[d] = std::clamp<int64_t>(k, -kCellBias + kReach, kCellBias - 1 - kReach);
    }
    return c;
  }
  static uint64_t pack(const std::array<int64_t, D>& c) {
    uint64_t key = 0;
    for (int d = 0; d < D; ++d) key |= static_cast<uint64_t>(c[d] + kCellBias) << (kCellBits * (D - 1 - d));
    return key;
  }
  static std::array<int64_t, D> unpack(uint64_t key) {
    std::array<int64_t, D> c;
    const uint64_t mask = (uint64_t{1} << kCellBits) - 1;
    for (int d = 0; d < D; ++d)
      c[d] = static_cast<int64_t>((key >> (kCellBits * (D - 1 - d))) & mask) - kCellBias;
    return c;
  }
  bool column(const std::vector<uint64_t>& keys, const std::vector<uint32_t>& begin, const std::array<int64_t, D>& c,
              int o, Block& out, size_t& hint) const;
};

// Column block o (0..kNb-1) around cell c within the cells `keys` (sorted, with particle offsets `begin`):
// false when the column holds no particles. `hint` is where the same column of the previous cell started:
// cells are visited in key order, so the search gallops forward from there (a binary search otherwise).
template <int D>
bool CellIndex<D>::column(const std::vector<uint64_t>& keys, const std::vector<uint32_t>& begin,
                          const std::array<int64_t, D>& c, int o, Block& out, size_t& hint) const {
  std::array<int64_t, D> lo = c, hi = c;
  uint32_t shift = 0;
  int rem = o, pw = 1;
  for (int d = 0; d < D - 1; ++d) {
    int64_t n = c[d] + rem % kSpan - kReach;
    rem /= kSpan;
    int s = 0;
    if (periodic_cells[d] > 0) {
      if (n >= periodic_cells[d]) {
        n -= periodic_cells[d];
        s = 1;
      } else if (n < 0) {
        n += periodic_cells[d];
        s = -1;
      }
    }
    lo[d] = hi[d] = n;
    shift += static_cast<uint32_t>((s + 1) * pw);
    pw *= 3;
  }
  lo[D - 1] = c[D - 1] - kReach;
  hi[D - 1] = c[D - 1] + kReach;
  const uint64_t key_lo = pack(lo), key_hi = pack(hi);
  const size_t nk = keys.size();
  size_t a = 0, b = nk;  // keys[a - 1] < key_lo <= keys[b] (as far as known)
  if (hint < nk && keys[hint] < key_lo) {
    size_t step = 1;
    a = hint + 1;
    while (a + step - 1 < nk && keys[a + step - 1] < key_lo) {
      a += step;
      step *= 2;
    }
    b = std::min(nk, a + step - 1);
  } else if (hint < nk) {
    b = hint;
  }
  const size_t k0 = std::lower_bound(keys.begin() + a, keys.begin() + b, key_lo) - keys.begin();
  hint = k0;
  size_t k1 = k0;
  while (k1 < nk && keys[k1] <= key_hi) ++k1;  // at most 2 kReach + 1 cells
  if (k0 >= k1) return false;
  out = {begin[k0], begin[k1], shift, static_cast<uint32_t>(k0), static_cast<uint32_t>(k1)};
  return true;
}

// Pair lists (pair_lists.cpp), per thread, and per fluid particle where its list is: its entries start at
// off[i] in thread[i]'s buffer, nf fluid then nb wall neighbours.
struct PairLists {
  std::vector<std::vector<uint32_t>> buf;
  std::vector<uint32_t> off, nf, nb;
  std::vector<uint16_t> thread;
  const uint32_t* of(uint32_t i) const { return buf[thread[i]].data() + off[i]; }
};

// The pairs inside the support at this evaluation, each fluid pair once, in the order a fresh scan of the
// cells would list them. With a skin (SolverConfig::neighbour_skin > 0): the candidates within support + skin
// when the cells were last sorted, kept until a particle may have moved half the skin
// (Solver::neighbour_lists_due); each evaluation keeps those now inside the support. Where the fluid was at
// that sort, and what else the candidates depend on.
template <int D>
struct NeighbourLists {
  PairLists lists;
  PairLists candidates;
  bool candidates_valid = false;
  std::array<std::vector<real>, D> pos_at_sort;
  size_t fluid_at_sort = 0;
  uint64_t generation_at_sort = 0;
  long neighbour_rebuilds = 0;
};

// What the pair passes read besides the particles, set once per evaluation, and what they accumulate into.
template <int D>
struct PassBuffers {
  // Per material: the Tait EOS, rho0, the tension floor (-tensile strength) and the wall friction coefficient.
  std::vector<TaitEOS> eos;
  std::vector<real> rho0, p_min, wall_friction;
  // Per particle, once per evaluation rather than per pair: volume m / rho and p / rho^2 (fluid; boundary:
  // the active ones).
  std::vector<real> vol, pt, inv_rho, bvol, bpt;
  // What a pair loop reads of its neighbour j, one record per fluid particle (Pack<D>, pass_context.hpp).
  std::vector<real> neighbour_pack;
  // Per-thread accumulators of the pair passes.
  std::vector<std::vector<real>> acc_f, acc_b;
  PassMaxima maxima;
  // The implicit viscous step's pair weights (implicit_viscosity.cpp), laid out as the lists' buffers.
  std::vector<std::vector<real>> visc_pair;
  // Per fluid particle, the friction drag of the implicit step and its wall normal (pass_context.hpp).
  std::vector<real> friction_drag;
  std::array<std::vector<real>, D> friction_normal;
  // Particle shifting (shifting.cpp): per fluid particle, grad C and the free-surface scale (0 at a surface).
  std::array<std::vector<real>, D> shift_gradient;
  std::vector<real> shift_scale;
};

// Wall tiles (wall_tiles.cpp). Per boundary particle: its tile (-1: a fixed particle, always alive) and its
// rank in the cell sort's ties (fixed: its place in the scene; a tile's: fixed count + its source index), so
// a cell's particles keep one order whichever tiles are alive. Per tile: alive or not, and the stamp of the
// last rebuild that wanted it.
template <int D>
struct WallTiles {
  WallTileGrid grid;
  std::vector<int64_t> of_wall;
  std::vector<uint64_t> rank;
  size_t fixed = 0;  // the boundary particles the scene gives (not a source's tiles): the first ones
  std::vector<char> live;
  std::vector<uint32_t> mark;
  uint32_t mark_stamp = 0;
  std::vector<int64_t> alive;  // the live tiles, ascending
  // Where the flow stood when every tile within check_reach of it was last known alive (permuted with the
  // fluid by the cell sort; reach < 0: not known). Until a particle has moved farther than that reach less
  // the one it needs now, no tile it needs can be missing, and the step's check is skipped.
  std::array<std::vector<real>, D> check_pos;
  real check_reach = -1;
};

// Buffers the cell sort permutes through.
struct SortScratch {
  std::vector<real> reals;
  std::vector<uint32_t> u32s;
  std::vector<uint16_t> u16s;
};

}  // namespace solver_detail
using namespace solver_detail;

// The solver's private state, by owner: the cells, the pair lists, the passes' buffers, the wall tiles.
template <int D>
struct Solver<D>::Impl {
  CellIndex<D> cells;
  NeighbourLists<D> pairs;
  PassBuffers<D> pass;
  WallTiles<D> tiles;
  SortScratch scratch;

  const uint32_t* list_of(uint32_t i) const { return pairs.lists.of(i); }
  template <class F>
  void for_each_fluid(F&& f) const {
    cells.for_each_fluid(std::forward<F>(f));
  }

  // Runs body(A, Bacc, maxima) in a parallel region in which each thread owns accumulators A (nf_fields values
  // per fluid particle, particle-major so one pair's updates share a cache line) and Bacc (nb_fields per active
  // boundary particle), zeroed; then, after the barrier, finish_fluid(sum, i, maxima) for each of the n fluid
  // particles with sum(f, i) the total over threads, and finish_boundary(bsum, b, slot) for every active
  // boundary particle. Each thread's maxima are merged into pass.maxima.
  template <class Body, class FinishFluid, class FinishBoundary>
  void accumulate(size_t n, int nf_fields, int nb_fields, Body&& body, FinishFluid&& finish_fluid,
                  FinishBoundary&& finish_boundary) {
    const size_t nslots = cells.active_boundary_count;
    auto& acc_f = pass.acc_f;
    auto& acc_b = pass.acc_b;
#pragma omp parallel
    {
      const int t = omp_get_thread_num();
      const int T = omp_get_num_threads();
      PassMaxima own;
      auto& A = acc_f[t];
      auto& Bacc = acc_b[t];
      A.assign(static_cast<size_t>(nf_fields) * n, 0.0);
      Bacc.assign(static_cast<size_t>(nb_fields) * nslots, 0.0);
      body(A.data(), Bacc.data(), own);
      // (the worksharing loop in body ends with a barrier: every thread's accumulators are complete)
      auto fsum = [&](int f, size_t i) {
        real s = 0;
        for (int u = 0; u < T; ++u) s += acc_f[u][i * nf_fields + f];
        return s;
      };
      auto bsum = [&](int f, size_t q) {
        real s = 0;
        for (int u = 0; u < T; ++u) s += acc_b[u][q * nb_fields + f];
        return s;
      };
#pragma omp for schedule(static)
      for (size_t i = 0; i < n; ++i) finish_fluid(fsum, i, own);
      if (nb_fields > 0) {
#pragma omp for schedule(static)
        for (size_t a = 0; a < cells.active_bcells.size(); ++a) {
          const uint32_t cb = cells.active_bcells[a];
          for (uint32_t b = cells.bcell_begin[cb]; b < cells.bcell_begin[cb + 1]; ++b)
            finish_boundary(bsum, b, cells.bslot[b]);
        }
      }
#pragma omp critical(runout_pass_maxima)
      pass.maxima.merge(own);
    }
  }
};

}  // namespace runout
