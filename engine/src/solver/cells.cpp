#include "impl.hpp"

#include "../ordered_sum.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace runout {
namespace {

// Per fluid cell, the column blocks o0..kNb-1 around it of the cells `keys` (with particle offsets `begin`) that
// hold particles, `stride` slots per cell in `blocks`, their number in `count`.
template <int D>
void index_columns(const CellIndex<D>& cells, const std::vector<uint64_t>& keys, const std::vector<uint32_t>& begin,
                   int o0, int stride, std::vector<typename CellIndex<D>::Block>& blocks, std::vector<uint8_t>& count) {
  using Cells = CellIndex<D>;
  const size_t ncells = cells.fcell_key.size();
  blocks.resize(ncells * stride);
  count.assign(ncells, 0);
#pragma omp parallel
  {
    std::array<size_t, Cells::kNb> hint{};
#pragma omp for schedule(static)
    for (size_t c = 0; c < ncells; ++c) {
      const auto cc = Cells::unpack(cells.fcell_key[c]);
      int m = 0;
      typename Cells::Block blk;
      for (int o = o0; o < Cells::kNb; ++o)
        if (cells.column(keys, begin, cc, o, blk, hint[o])) blocks[c * stride + m++] = blk;
      count[c] = static_cast<uint8_t>(m);
    }
  }
}

}  // namespace

// Sorts fluid particles by cell, removes outflow, and builds the neighbour blocks of every fluid cell and
// of the boundary cells next to fluid.
template <int D>
void Solver<D>::sort_and_build_cells() {
  auto& I = *impl_;
  auto& cells = I.cells;
  auto& tiles = I.tiles;
  const size_t n = fluid_.size();
  cells.sort_buf.resize(n);
  // sums[0]: particles removed; sums[1]: the change of -m g.x from this step's periodic wraps (not a physical
  // change of PE). Ordered sums: the energy series repeats to the bit (ordered_sum.hpp).
  const auto sums = ordered_sums<2>(n, [&](size_t i, std::array<real, 2>& s) {
    Vec<D> p = fluid_.position(i);
    for (int d = 0; d < D; ++d) {
      if (config_.periodic[d]) {
        const real L = cells.period[d];
        real x = p[d] - config_.domain_min[d];
        if (x < 0 || x >= L) {
          x -= std::floor(x / L) * L;
          if (x >= L) x = 0;
          s[1] -= fluid_.mass[i] * config_.gravity[d] * (config_.domain_min[d] + x - p[d]);
          p[d] = config_.domain_min[d] + x;
          fluid_.pos[d][i] = p[d];
          if (config_.integrator == Integrator::verlet) saved_.pos[d][i] = p[d];
        }
      }
    }
    const bool out = removed_at_sort(p, fluid_.tag[i]) || (!outflow_marked_.empty() && outflow_marked_[i]);
    cells.sort_buf[i] = {out ? kRemovedKey : CellIndex<D>::pack(cells.coords(p)), static_cast<uint32_t>(i)};
    s[0] += out ? 1 : 0;
  });
  const size_t removed = static_cast<size_t>(sums[0]);
  const real wrap_pe = sums[1];
  balance_.potential_outflow -= wrap_pe;  // keeps PE(t) + balance_.potential_outflow continuous across a wrap
  I.pairs.candidates_valid = false;
  outflow_marked_.clear();
  std::sort(cells.sort_buf.begin(), cells.sort_buf.end());
  const size_t keep = n - removed;
  if (removed > 0) {
    for (size_t k = keep; k < n; ++k) {
      const uint32_t i = cells.sort_buf[k].second;
      balance_.mass.outflow[fluid_.material[i]] += fluid_.mass[i];
      real gx = 0;
      for (int d = 0; d < D; ++d) gx += config_.gravity[d] * fluid_.pos[d][i];
      balance_.potential_outflow -= fluid_.mass[i] * gx;
    }
  }

  // Apply the permutation (and truncation) to every per-particle array that carries state.
  auto permute_real = [&](std::vector<real>& v) {
    I.scratch.reals.resize(keep);
#pragma omp parallel for
    for (size_t k = 0; k < keep; ++k) I.scratch.reals[k] = v[cells.sort_buf[k].second];
    v.swap(I.scratch.reals);
  };
  for (int d = 0; d < D; ++d) {
    permute_real(fluid_.pos[d]);
    permute_real(fluid_.vel[d]);
    if (config_.integrator == Integrator::verlet) {
      permute_real(saved_.pos[d]);
      permute_real(saved_.vel[d]);
    }
  }
  if (tiles.check_reach >= 0 && tiles.check_pos[0].size() == n)
    for (int d = 0; d < D; ++d) permute_real(tiles.check_pos[d]);
  else
    tiles.check_reach = -1;
  permute_real(fluid_.rho);
  permute_real(fluid_.mass);
  if (config_.integrator == Integrator::verlet) permute_real(saved_.rho);
  {
    I.scratch.u16s.resize(keep);
    for (size_t k = 0; k < keep; ++k) I.scratch.u16s[k] = fluid_.material[cells.sort_buf[k].second];
    fluid_.material.swap(I.scratch.u16s);
    I.scratch.u32s.resize(keep);
    for (size_t k = 0; k < keep; ++k) I.scratch.u32s[k] = fluid_.tag[cells.sort_buf[k].second];
    fluid_.tag.swap(I.scratch.u32s);
    I.scratch.u32s.resize(keep);
    for (size_t k = 0; k < keep; ++k) I.scratch.u32s[k] = fluid_.id[cells.sort_buf[k].second];
    fluid_.id.swap(I.scratch.u32s);
  }

  // Fluid cells.
  cells.fcell_key.clear();
  cells.fcell_begin.clear();
  for (size_t k = 0; k < keep; ++k) {
    const uint64_t key = cells.sort_buf[k].first;
    if (cells.fcell_key.empty() || cells.fcell_key.back() != key) {
      cells.fcell_key.push_back(key);
      cells.fcell_begin.push_back(static_cast<uint32_t>(k));
    }
  }
  cells.fcell_begin.push_back(static_cast<uint32_t>(keep));
  // Column o has horizontal offsets (o % 5 - 2, o / 5 - 2): o > kNb / 2 is the half after the own column.
  index_columns(cells, cells.fcell_key, cells.fcell_begin, CellIndex<D>::kNb / 2, CellIndex<D>::kHalf, cells.fnb_half,
                cells.fnb_half_n);
  index_wall_blocks();

  fluid_fields_.resize(keep);  // they follow the (possibly smaller) particle count
}

template <int D>
void Solver<D>::FluidFields::resize(size_t n) {
  for (int d = 0; d < D; ++d) acc[d].resize(n), contact_normal[d].assign(n, 0);
  drho.resize(n);
  pressure.resize(n);
  mu_eff.resize(n);
  shear_rate.resize(n);
  yield_pressure.resize(n);
  mu_wall.resize(n);
  zero_pressure.resize(n);
}

// The wall columns around each fluid cell, and the wall cells next to fluid: the only wall particles that do
// work until the next sort. Wall blocks are runs of whole wall cells, so mark the cells each run covers.
template <int D>
void Solver<D>::index_wall_blocks() {
  auto& I = *impl_;
  auto& cells = I.cells;
  constexpr int kNb = CellIndex<D>::kNb;
  const size_t ncells = cells.fcell_key.size();
  index_columns(cells, cells.bcell_key, cells.bcell_begin, 0, kNb, cells.fnb_bound, cells.fnb_bound_n);
  ++cells.stamp;
  cells.active_bcells.clear();
  for (size_t c = 0; c < ncells; ++c) {
    for (int k = 0; k < cells.fnb_bound_n[c]; ++k) {
      const auto& blk = cells.fnb_bound[c * kNb + k];
      for (uint32_t cb = blk.cell0; cb < blk.cell1; ++cb) {
        if (cells.bcell_stamp[cb] != cells.stamp) {
          cells.bcell_stamp[cb] = cells.stamp;
          cells.active_bcells.push_back(static_cast<uint32_t>(cb));
        }
      }
    }
  }
  cells.bslot.resize(boundary_.size());
  uint32_t slot = 0;
  for (uint32_t cb : cells.active_bcells)
    for (uint32_t b = cells.bcell_begin[cb]; b < cells.bcell_begin[cb + 1]; ++b) cells.bslot[b] = slot++;
  cells.active_boundary_count = slot;
}

// A particle at p the sort removes: past an open face, or flow back inside an inlet's buffer.
template <int D>
bool Solver<D>::removed_at_sort(const Vec<D>& p, uint32_t tag) const {
  for (int d = 0; d < D; ++d)
    if (!config_.periodic[d] && ((p[d] < config_.domain_min[d] && config_.outflow[d][0]) ||
                                 (p[d] > config_.domain_max[d] && config_.outflow[d][1])))
      return true;
  return !inlets_.empty() && !is_inlet_buffer(tag) && in_inlet_buffer(p);
}

// Whether the next sort would wrap or remove fluid particle i.
template <int D>
bool Solver<D>::leaves_sorted_cells(size_t i) const {
  const Vec<D> p = fluid_.position(i);
  for (int d = 0; d < D; ++d) {
    if (!config_.periodic[d]) continue;
    const real x = p[d] - config_.domain_min[d];
    if (x < 0 || x >= impl_->cells.period[d]) return true;
  }
  return removed_at_sort(p, fluid_.tag[i]);
}

template void Solver<2>::sort_and_build_cells();
template void Solver<2>::FluidFields::resize(size_t);
template void Solver<3>::FluidFields::resize(size_t);
template void Solver<3>::sort_and_build_cells();
template void Solver<2>::index_wall_blocks();
template void Solver<3>::index_wall_blocks();
template bool Solver<2>::removed_at_sort(const Vec<2>&, uint32_t) const;
template bool Solver<3>::removed_at_sort(const Vec<3>&, uint32_t) const;
template bool Solver<2>::leaves_sorted_cells(size_t) const;
template bool Solver<3>::leaves_sorted_cells(size_t) const;

}  // namespace runout
