// Pair lists: for every fluid particle i, its fluid neighbours j > i in the half stencil (the own column with
// higher indices, and the columns "after" it), so each fluid pair is listed once, then all its wall neighbours.
// The passes (passes.hpp) walk these lists. Without a skin each evaluation scans the cells for them; with one,
// the cells are scanned for candidates within support + skin only when they are sorted, and each evaluation
// keeps the candidates now inside the support (a Verlet list: docs/performance.md, "Verlet lists").
#include <unordered_set>

#include "impl.hpp"

namespace runout {

namespace {

// |x - q_k|^2 for a contiguous run of particles (SoA): a plain vector loop.
void distances_squared3(const real* __restrict a, const real* __restrict b, const real* __restrict c, real xa, real xb,
                        real xc, uint32_t m, real* __restrict out) {
  for (uint32_t k = 0; k < m; ++k) {
    const real da = xa - a[k], db = xb - b[k], dc = xc - c[k];
    out[k] = da * da + db * db + dc * dc;
  }
}
void distances_squared2(const real* __restrict a, const real* __restrict b, real xa, real xb, uint32_t m,
                        real* __restrict out) {
  for (uint32_t k = 0; k < m; ++k) {
    const real da = xa - a[k], db = xb - b[k];
    out[k] = da * da + db * db;
  }
}

template <class Lists>
void size_lists(Lists& L, size_t n) {
  L.buf.resize(omp_get_max_threads());
  L.off.resize(n);
  L.nf.resize(n);
  L.nb.resize(n);
  L.thread.resize(n);
}

// One thread's share of pair lists L (inside the parallel region): entries go to the thread's buffer at `pos`,
// and a particle's list is recorded by where it starts and how many of its entries are fluid.
template <class Lists>
struct ListWriter {
  Lists& L;
  int t = omp_get_thread_num();
  std::vector<uint32_t>& buf;
  size_t pos = 0;
  explicit ListWriter(Lists& lists) : L(lists), buf(lists.buf[omp_get_thread_num()]) {}
  uint32_t* reserve(size_t m) {
    if (buf.size() < pos + m) buf.resize(std::max<size_t>(2 * buf.size(), pos + m + 1024));
    return buf.data();
  }
  void record(uint32_t i, size_t start, size_t nf) {
    L.thread[i] = static_cast<uint16_t>(t);
    L.off[i] = static_cast<uint32_t>(start);
    L.nf[i] = static_cast<uint32_t>(nf);
    L.nb[i] = static_cast<uint32_t>(pos - start - nf);
  }
};

}  // namespace

// The listing test is branch-free: the store is unconditional and the cursor advances by the test's outcome,
// so the ~3/4 of candidates outside the support cost no mispredicted branch.
template <int D>
void Solver<D>::scan_cells_for_pairs(real radius, bool into_candidates) {
  auto& I = *impl_;
  auto& cells = I.cells;
  constexpr int kNb = CellIndex<D>::kNb, kHalf = CellIndex<D>::kHalf;
  const size_t n = fluid_.size(), ncells = cells.fcell_key.size();
  const real support2 = radius * radius;
  std::array<const real*, D> P, BP;
  for (int d = 0; d < D; ++d) P[d] = fluid_.pos[d].data(), BP[d] = boundary_.pos[d].data();
  auto& L = into_candidates ? I.pairs.candidates : I.pairs.lists;
  size_lists(L, n);
#pragma omp parallel
  {
    ListWriter<PairLists> w(L);
    std::vector<real> r2buf;
    // Distances of a contiguous run first (a vector loop), then the branch-free compaction.
    auto scan = [&](const std::array<const real*, D>& Q, const Vec<D>& xs, uint32_t j0, uint32_t j1) {
      if (j1 <= j0) return;
      const uint32_t m = j1 - j0;
      uint32_t* out = w.reserve(m);
      if (r2buf.size() < m) r2buf.resize(std::max<size_t>(m, 2 * r2buf.size()));
      real* __restrict r2s = r2buf.data();
      if constexpr (D == 3)
        distances_squared3(Q[0] + j0, Q[1] + j0, Q[2] + j0, xs[0], xs[1], xs[2], m, r2s);
      else
        distances_squared2(Q[0] + j0, Q[1] + j0, xs[0], xs[1], m, r2s);
      for (uint32_t k = 0; k < m; ++k) {
        out[w.pos] = j0 + k;
        w.pos += (r2s[k] < support2) & (r2s[k] >= 1e-24);
      }
    };
#pragma omp for schedule(dynamic, 16)
    for (size_t c = 0; c < ncells; ++c) {
      for (uint32_t i = cells.fcell_begin[c]; i < cells.fcell_begin[c + 1]; ++i) {
        Vec<D> xi;
        for (int d = 0; d < D; ++d) xi[d] = P[d][i];
        const size_t start = w.pos;
        for (int k = 0; k < cells.fnb_half_n[c]; ++k) {
          const auto& blk = cells.fnb_half[c * kHalf + k];
          // Block 0 is the particle's own column: only the higher indices (the pair's other half is listed by
          // the lower-index particle).
          scan(P, xi - cells.shifts[blk.shift], k == 0 ? i + 1 : blk.begin, blk.end);
        }
        const size_t nf = w.pos - start;
        for (int k = 0; k < cells.fnb_bound_n[c]; ++k) {
          const auto& blk = cells.fnb_bound[c * kNb + k];
          scan(BP, xi - cells.shifts[blk.shift], blk.begin, blk.end);
        }
        w.record(i, start, nf);
      }
    }
  }
}

// The candidates now inside the support, in their order (so the lists are those a scan of the same cells would
// make); the test is the scan's, branch-free.
template <int D>
void Solver<D>::keep_pairs_in_support(real support) {
  auto& I = *impl_;
  const size_t n = fluid_.size();
  const real support2 = support * support;
  std::array<const real*, D> P, BP;
  for (int d = 0; d < D; ++d) P[d] = fluid_.pos[d].data(), BP[d] = boundary_.pos[d].data();
  const Vec<D> period = I.cells.period;
  bool periodic = false;
  for (int d = 0; d < D; ++d) periodic = periodic || period[d] > 0;
  const auto& C = I.pairs.candidates;
  auto& L = I.pairs.lists;
  size_lists(L, n);
#pragma omp parallel
  {
    ListWriter<PairLists> w(L);
    auto keep = [&](const std::array<const real*, D>& Q, const Vec<D>& xi, const uint32_t* js, uint32_t m) {
      uint32_t* out = w.reserve(m);
      for (uint32_t k = 0; k < m; ++k) {
        const uint32_t j = js[k];
        real r2 = 0;
        for (int d = 0; d < D; ++d) {
          real dxd = xi[d] - Q[d][j];
          if (periodic && period[d] > 0) dxd -= period[d] * std::round(dxd / period[d]);
          r2 += dxd * dxd;
        }
        out[w.pos] = j;
        w.pos += (r2 < support2) & (r2 >= 1e-24);
      }
    };
    I.for_each_fluid([&](uint32_t i) {
      Vec<D> xi;
      for (int d = 0; d < D; ++d) xi[d] = P[d][i];
      const size_t start = w.pos;
      const uint32_t* js = C.of(i);
      keep(P, xi, js, C.nf[i]);
      const size_t nf = w.pos - start;
      keep(BP, xi, js + C.nf[i], C.nb[i]);
      w.record(i, start, nf);
    });
  }
}

// The lists for this evaluation: scanned from the cells without a skin; with one, from the candidates, which
// are scanned (within support + skin) only after a sort and remembered with where the fluid stood.
template <int D>
void Solver<D>::update_pair_lists(real support) {
  auto& pairs = impl_->pairs;
  const real skin = neighbour_skin();
  if (skin <= 0) {
    scan_cells_for_pairs(support, false);
    ++pairs.neighbour_rebuilds;
    return;
  }
  if (!pairs.candidates_valid) {
    scan_cells_for_pairs(support + skin, true);
    for (int d = 0; d < D; ++d) pairs.pos_at_sort[d] = fluid_.pos[d];
    pairs.fluid_at_sort = fluid_.size();
    pairs.generation_at_sort = boundary_generation_;
    pairs.candidates_valid = true;
    ++pairs.neighbour_rebuilds;
  } else if (pairs.generation_at_sort != boundary_generation_) {
    rescan_at_sort();
  }
  keep_pairs_in_support(support);
}

// The walls alive changed (and were re-sorted) since the cells were: the candidates are scanned again where
// the fluid stood at that sort, so they are those the sort would have found among these walls, whenever the
// walls changed (a bed laid near the flow gives the run of a bed laid whole, to the bit).
template <int D>
void Solver<D>::rescan_at_sort() {
  auto& pairs = impl_->pairs;
  for (int d = 0; d < D; ++d) std::swap(fluid_.pos[d], pairs.pos_at_sort[d]);
  index_wall_blocks();
  scan_cells_for_pairs(2.0 * config_.smoothing_length + neighbour_skin(), true);
  for (int d = 0; d < D; ++d) std::swap(fluid_.pos[d], pairs.pos_at_sort[d]);
  pairs.generation_at_sort = boundary_generation_;
  ++pairs.neighbour_rebuilds;
}

// Whether the cells must be sorted (and the candidates scanned) before this step's first evaluation: always
// without a skin; with one, when particles were added or removed since the last sort, a particle must leave
// (outflow, an inlet's buffer) or wrap, or a pair may have closed in by the skin by the step's second
// evaluation. Two particles close in by at most the sum of their displacements since the sort plus, by then,
// half a step each (a step is at most cfl h / c0). A wall particle does not move: a fluid particle closes in
// on it by its own displacement only.
template <int D>
bool Solver<D>::neighbour_lists_due() const {
  const auto& pairs = impl_->pairs;
  const real skin = neighbour_skin();
  if (skin <= 0 || !pairs.candidates_valid || fluid_.size() != pairs.fluid_at_sort || !outflow_marked_.empty()) return true;
  const size_t n = fluid_.size();
  real disp2 = 0, speed2 = 0;
  bool leaving = false;
#pragma omp parallel for schedule(static) reduction(max : disp2, speed2) reduction(|| : leaving)
  for (size_t i = 0; i < n; ++i) {
    real dd = 0, vv = 0;
    for (int d = 0; d < D; ++d) {
      const real u = fluid_.pos[d][i] - pairs.pos_at_sort[d][i];
      dd += u * u, vv += fluid_.vel[d][i] * fluid_.vel[d][i];
    }
    disp2 = std::max(disp2, dd), speed2 = std::max(speed2, vv);
    leaving = leaving || leaves_sorted_cells(i);
  }
  const real half_step = 0.5 * config_.cfl * config_.smoothing_length / config_.speed_of_sound;
  return leaving || 2.0 * (std::sqrt(disp2) + half_step * std::sqrt(speed2)) >= skin;
}

template <int D>
long Solver<D>::neighbour_list_builds() const {
  return impl_->pairs.neighbour_rebuilds;
}

template <int D>
size_t Solver<D>::missing_neighbour_pairs() const {
  const auto& I = *impl_;
  const auto& cells = I.cells;
  // The next step sorts and scans afresh, or scans the walls again.
  if (neighbour_lists_due() || I.pairs.generation_at_sort != boundary_generation_) return 0;
  const real support = 2.0 * config_.smoothing_length, support2 = support * support;
  const auto& C = I.pairs.candidates;
  const size_t n = fluid_.size(), nb = boundary_.size();
  std::unordered_set<uint64_t> fluid_pairs, wall_pairs;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t* js = C.of(static_cast<uint32_t>(i));
    for (uint32_t k = 0; k < C.nf[i]; ++k)
      fluid_pairs.insert(uint64_t{std::min<uint32_t>(i, js[k])} << 32 | std::max<uint32_t>(i, js[k]));
    for (uint32_t k = C.nf[i]; k < C.nf[i] + C.nb[i]; ++k) wall_pairs.insert(uint64_t{uint32_t(i)} << 32 | js[k]);
  }
  auto r2_of = [&](const ParticleArrays<D>& q, size_t i, size_t j) {
    real r2 = 0;
    for (int d = 0; d < D; ++d) {
      real dxd = fluid_.pos[d][i] - q.pos[d][j];
      if (cells.period[d] > 0) dxd -= cells.period[d] * std::round(dxd / cells.period[d]);
      r2 += dxd * dxd;
    }
    return r2;
  };
  size_t missing = 0;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const real r2 = r2_of(fluid_, i, j);
      if (r2 < support2 && r2 >= 1e-24 && !fluid_pairs.count(uint64_t{uint32_t(i)} << 32 | uint32_t(j))) ++missing;
    }
    for (size_t b = 0; b < nb; ++b) {
      const real r2 = r2_of(boundary_, i, b);
      if (r2 < support2 && r2 >= 1e-24 && !wall_pairs.count(uint64_t{uint32_t(i)} << 32 | uint32_t(b))) ++missing;
    }
  }
  return missing;
}

#define RUNOUT_INSTANTIATE_PAIR_LISTS(D)                     \
  template void Solver<D>::scan_cells_for_pairs(real, bool); \
  template void Solver<D>::keep_pairs_in_support(real);      \
  template void Solver<D>::update_pair_lists(real);          \
  template void Solver<D>::rescan_at_sort();                 \
  template bool Solver<D>::neighbour_lists_due() const;    \
  template long Solver<D>::neighbour_list_builds() const;  \
  template size_t Solver<D>::missing_neighbour_pairs() const;
RUNOUT_INSTANTIATE_PAIR_LISTS(2)
RUNOUT_INSTANTIATE_PAIR_LISTS(3)
#undef RUNOUT_INSTANTIATE_PAIR_LISTS

}  // namespace runout
