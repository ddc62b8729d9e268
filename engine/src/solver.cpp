#include "runout/engine/solver.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace runout {

template <int D>
void ParticleArrays<D>::add(const Vec<D>& p, real density, real m, uint16_t mat, uint32_t tg) {
  for (int d = 0; d < D; ++d) {
    pos[d].push_back(p[d]);
    vel[d].push_back(0.0);
  }
  rho.push_back(density);
  mass.push_back(m);
  material.push_back(mat);
  tag.push_back(tg);
  id.push_back(static_cast<uint32_t>(id.size()));
}

long double MassBalance::total_initial() const { return std::accumulate(initial.begin(), initial.end(), 0.0L); }
long double MassBalance::total_current() const { return std::accumulate(current.begin(), current.end(), 0.0L); }
long double MassBalance::total_outflow() const { return std::accumulate(outflow.begin(), outflow.end(), 0.0L); }
long double MassBalance::total_inflow() const { return std::accumulate(inflow.begin(), inflow.end(), 0.0L); }

template <int D>
real InletSpec<D>::speed_at(real t) const {
  if (speed.empty()) return 0;
  if (t <= speed.front()[0]) return speed.front()[1];
  for (size_t k = 1; k < speed.size(); ++k)
    if (t < speed[k][0]) {
      const auto& a = speed[k - 1];
      const auto& b = speed[k];
      return a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0]);
    }
  return speed.back()[1];
}

namespace {

constexpr int kCellBits = 21;
constexpr int64_t kCellBias = int64_t{1} << (kCellBits - 1);
constexpr uint64_t kRemovedKey = std::numeric_limits<uint64_t>::max();

std::string fmt_time(real t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "t=%.6g s", t);
  return buf;
}

}  // namespace

// Cell grid and neighbour blocks. Cells have size h (half the kernel support) and are searched two cells
// each way. Keys pack the vertical axis in the lowest bits, so the five cells of one vertical column are
// contiguous in sorted order: each neighbour "block" is one such column run (5 blocks per cell in 2D, 25 in
// 3D) plus the periodic image shift to apply to it.
template <int D>
struct Solver<D>::Impl {
  struct Block {
    uint32_t begin, end, shift;
    uint32_t cell0, cell1;  // the cells (indices into the key array) the run covers
  };
  static constexpr int kReach = 2;
  static constexpr int kSpan = 2 * kReach + 1;
  static constexpr int kNb = D == 2 ? kSpan : kSpan * kSpan;

  Vec<D> origin, cell_size, inv_cell, period;
  std::array<int64_t, D> periodic_cells{};  // 0 if the axis is not periodic
  std::vector<Vec<D>> shifts;                // 3^(D-1) entries, index sum (s_d + 1) 3^d over horizontal axes

  std::vector<uint64_t> fcell_key;
  std::vector<uint32_t> fcell_begin;  // size cells + 1
  std::vector<Block> fnb_bound;  // boundary columns, stride kNb per fluid cell
  std::vector<uint8_t> fnb_bound_n;

  std::vector<uint64_t> bcell_key;
  std::vector<uint32_t> bcell_begin;
  std::vector<uint32_t> bcell_stamp;
  uint32_t stamp = 0;
  std::vector<uint32_t> active_bcells;
  // Active boundary particles (those in active cells) numbered 0.. in active-cell order: bslot[b] is valid
  // for them only. Per-thread boundary accumulators are this long, not the whole boundary's length.
  std::vector<uint32_t> bslot;
  size_t active_boundary_count = 0;

  // Half stencil of fluid columns (the own column first, then those after it: each pair once), stride kHalf.
  static constexpr int kHalf = kNb / 2 + 1;
  std::vector<Block> fnb_half;
  std::vector<uint8_t> fnb_half_n;

  // Pair lists (see evaluate), per thread, and per fluid particle where its list is.
  std::vector<std::vector<uint32_t>> list_buf;
  std::vector<uint32_t> list_off, list_nf, list_nb;
  std::vector<uint16_t> list_thread;
  // Per-thread accumulators of the pair passes.
  std::vector<std::vector<real>> acc_f, acc_b;
  // Per particle, once per evaluation rather than per pair: volume m / rho and p / rho^2 (fluid; boundary:
  // the active ones).
  std::vector<real> vol, pt, inv_rho, bvol, bpt;
  // What a pair loop reads of its neighbour j, packed in one 64-byte record per fluid particle (one cache
  // line instead of one per array): velocity, rho, m / rho, p / rho^2, p (pass 1) or mu_eff (pass 2), 1 / rho.
  static constexpr int kPackStride = 8, kPackRho = D, kPackVol = D + 1, kPackPt = D + 2, kPackPm = D + 3,
                       kPackInvRho = D + 4;
  static_assert(kPackInvRho < kPackStride);
  std::vector<real> neighbour_pack;

  std::vector<std::pair<uint64_t, uint32_t>> sort_buf;
  std::vector<real> scratch_real;
  std::vector<uint32_t> scratch_u32;
  std::vector<uint16_t> scratch_u16;

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
  // Column block o (0..kNb-1) around cell c within the cells `keys` (sorted, with particle offsets `begin`):
  // false when the column holds no particles. `hint` is where the same column of the previous cell started:
  // cells are visited in key order, so the search gallops forward from there (a binary search otherwise).
  bool column(const std::vector<uint64_t>& keys, const std::vector<uint32_t>& begin, const std::array<int64_t, D>& c,
              int o, Block& out, size_t& hint) const {
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
};

template <int D>
Solver<D>::Solver(SceneSetup<D> setup)
    : impl_(std::make_unique<Impl>()),
      config_(setup.config),
      materials_(std::move(setup.materials)),
      fluid_(std::move(setup.fluid)),
      boundary_(std::move(setup.boundary)),
      leak_regions_(std::move(setup.leak_regions)),
      inlets_(std::move(setup.inlets)) {
  auto& I = *impl_;
  for (const auto& m : materials_) rheologies_.push_back(make_rheology(m));
  for (uint32_t id : fluid_.id) next_id_ = std::max(next_id_, id + 1);
  create_inlet_buffers();

  const real h = config_.smoothing_length;
  const real support = 2.0 * h;
  // Auto viscosity cap: the mu_eff at which the viscous limit 0.125 h^2 rho / mu equals cfl h / c0.
  if (config_.max_viscosity > 0) {
    max_viscosity_ = config_.max_viscosity;
  } else {
    real rho_min = 1e300;
    for (const auto& m : materials_) rho_min = std::min(rho_min, m.density);
    max_viscosity_ = config_.viscosity_cap_factor * 0.125 * h * rho_min * config_.speed_of_sound / config_.cfl;
  }

  // Grid: cells of size h (half the support); a periodic axis gets a whole number (>= 5) of cells.
  for (int d = 0; d < D; ++d) {
    I.cell_size[d] = 0.5 * support;
    I.origin[d] = 0.0;
    I.period[d] = 0.0;
    if (config_.periodic[d]) {
      if (d == D - 1) throw std::invalid_argument("domain.periodic: the vertical axis cannot be periodic");
      const real L = config_.domain_max[d] - config_.domain_min[d];
      const int64_t n = static_cast<int64_t>(std::floor(L / (0.5 * support)));
      if (n < 2 * Impl::kReach + 1)
        throw std::invalid_argument("domain.periodic: a periodic axis must be at least 5h long");
      I.periodic_cells[d] = n;
      I.cell_size[d] = L / static_cast<real>(n);
      I.origin[d] = config_.domain_min[d];
      I.period[d] = L;
    }
    I.inv_cell[d] = 1.0 / I.cell_size[d];
  }
  // Non-periodic origin: the lower corner of all particles, so keys stay small.
  for (int d = 0; d < D; ++d) {
    if (config_.periodic[d]) continue;
    real lo = 1e300;
    for (real x : fluid_.pos[d]) lo = std::min(lo, x);
    for (real x : boundary_.pos[d]) lo = std::min(lo, x);
    I.origin[d] = (lo < 1e299 ? lo : 0.0) - support;
  }
  {
    int nshift = 1;
    for (int d = 0; d < D - 1; ++d) nshift *= 3;
    I.shifts.resize(nshift);
    for (int o = 0; o < nshift; ++o) {
      int rem = o;
      Vec<D> sv = Vec<D>::Zero();
      for (int d = 0; d < D - 1; ++d) {
        sv[d] = (rem % 3 - 1) * I.period[d];
        rem /= 3;
      }
      I.shifts[o] = sv;
    }
  }

  // Boundary particles never move: sort them by cell once.
  {
    const size_t nb = boundary_.size();
    std::vector<std::pair<uint64_t, uint32_t>> order(nb);
    for (size_t i = 0; i < nb; ++i) order[i] = {Impl::pack(I.coords(boundary_.position(i))), uint32_t(i)};
    std::sort(order.begin(), order.end());
    ParticleArrays<D> sorted;
    for (auto& [key, i] : order) {
      sorted.add(boundary_.position(i), boundary_.rho[i], boundary_.mass[i], boundary_.material[i],
                 boundary_.tag[i]);
      sorted.id.back() = boundary_.id[i];
      if (I.bcell_key.empty() || I.bcell_key.back() != key) {
        I.bcell_key.push_back(key);
        I.bcell_begin.push_back(static_cast<uint32_t>(sorted.size() - 1));
      }
    }
    I.bcell_begin.push_back(static_cast<uint32_t>(nb));
    boundary_ = std::move(sorted);
    I.bcell_stamp.assign(I.bcell_key.size(), 0);
  }
  boundary_drho_.assign(boundary_.size(), 0.0);
  boundary_pressure_.assign(boundary_.size(), 0.0);
  boundary_rho_saved_ = boundary_.rho;

  mass_.initial.assign(materials_.size(), 0.0L);
  mass_.outflow.assign(materials_.size(), 0.0L);
  mass_.inflow.assign(materials_.size(), 0.0L);
  for (size_t i = 0; i < fluid_.size(); ++i)
    if (!is_inlet_buffer(fluid_.tag[i])) mass_.initial[fluid_.material[i]] += fluid_.mass[i];
  potential_initial_ = potential_energy();
  // Verlet keeps the previous step's velocity and density in the saved arrays.
  for (int d = 0; d < D; ++d) {
    pos_saved_[d] = fluid_.pos[d];
    vel_saved_[d] = fluid_.vel[d];
  }
  rho_saved_ = fluid_.rho;
}

template <int D>
Solver<D>::~Solver() = default;

template <int D>
real Solver<D>::potential_energy() const {
  long double pe = 0;
  for (size_t i = 0; i < fluid_.size(); ++i) {
    if (is_inlet_buffer(fluid_.tag[i])) continue;
    real gx = 0;
    for (int d = 0; d < D; ++d) gx += config_.gravity[d] * fluid_.pos[d][i];
    pe -= fluid_.mass[i] * gx;
  }
  return static_cast<real>(pe);
}

template <int D>
MassBalance Solver<D>::mass_balance() const {
  MassBalance m = mass_;
  m.current.assign(materials_.size(), 0.0L);
  for (size_t i = 0; i < fluid_.size(); ++i)
    if (!is_inlet_buffer(fluid_.tag[i])) m.current[fluid_.material[i]] += fluid_.mass[i];
  return m;
}

template <int D>
EnergySummary Solver<D>::energy() const {
  EnergySummary e;
  long double ke = 0;
  for (size_t i = 0; i < fluid_.size(); ++i) {
    if (is_inlet_buffer(fluid_.tag[i])) continue;
    real v2 = 0;
    for (int d = 0; d < D; ++d) v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    ke += 0.5 * fluid_.mass[i] * v2;
  }
  e.kinetic = static_cast<real>(ke);
  e.potential_released = potential_initial_ - (potential_energy() + potential_outflow_);
  e.inflow_kinetic = kinetic_inflow_;
  return e;
}

template <int D>
void Solver<D>::remove_as_outflow(const std::vector<size_t>& indices) {
  if (indices.empty()) return;
  outflow_marked_.resize(fluid_.size(), 0);
  for (size_t i : indices) {
    if (i >= fluid_.size()) throw std::out_of_range("remove_as_outflow: fluid index out of range");
    outflow_marked_[i] = 1;
  }
  sort_and_build_cells();  // removes them now (the next step's sort would too, but a run may end first)
}

// Sorts fluid particles by cell, removes outflow, and builds the neighbour blocks of every fluid cell and
// of the boundary cells next to fluid.
template <int D>
void Solver<D>::sort_and_build_cells() {
  auto& I = *impl_;
  const size_t n = fluid_.size();
  I.sort_buf.resize(n);
  size_t removed = 0;
  real wrap_pe = 0;  // change of -m g.x from this step's periodic wraps: not a physical change of PE
#pragma omp parallel for reduction(+ : removed, wrap_pe)
  for (size_t i = 0; i < n; ++i) {
    Vec<D> p = fluid_.position(i);
    bool out = false;
    for (int d = 0; d < D; ++d) {
      if (config_.periodic[d]) {
        const real L = I.period[d];
        real x = p[d] - config_.domain_min[d];
        if (x < 0 || x >= L) {
          x -= std::floor(x / L) * L;
          if (x >= L) x = 0;
          wrap_pe -= fluid_.mass[i] * config_.gravity[d] * (config_.domain_min[d] + x - p[d]);
          p[d] = config_.domain_min[d] + x;
          fluid_.pos[d][i] = p[d];
          if (config_.integrator == Integrator::verlet) pos_saved_[d][i] = p[d];
        }
      } else if ((p[d] < config_.domain_min[d] && config_.outflow[d][0]) ||
                 (p[d] > config_.domain_max[d] && config_.outflow[d][1])) {
        out = true;
      }
    }
    if (!inlets_.empty() && !is_inlet_buffer(fluid_.tag[i])) out = out || in_inlet_buffer(p);
    if (!outflow_marked_.empty() && outflow_marked_[i]) out = true;
    I.sort_buf[i] = {out ? kRemovedKey : Impl::pack(I.coords(p)), static_cast<uint32_t>(i)};
    removed += out ? 1 : 0;
  }
  potential_outflow_ -= wrap_pe;  // keeps PE(t) + potential_outflow_ continuous across a wrap
  outflow_marked_.clear();
  std::sort(I.sort_buf.begin(), I.sort_buf.end());
  const size_t keep = n - removed;
  if (removed > 0) {
    for (size_t k = keep; k < n; ++k) {
      const uint32_t i = I.sort_buf[k].second;
      mass_.outflow[fluid_.material[i]] += fluid_.mass[i];
      real gx = 0;
      for (int d = 0; d < D; ++d) gx += config_.gravity[d] * fluid_.pos[d][i];
      potential_outflow_ -= fluid_.mass[i] * gx;
    }
  }

  // Apply the permutation (and truncation) to every per-particle array that carries state.
  auto permute_real = [&](std::vector<real>& v) {
    I.scratch_real.resize(keep);
#pragma omp parallel for
    for (size_t k = 0; k < keep; ++k) I.scratch_real[k] = v[I.sort_buf[k].second];
    v.swap(I.scratch_real);
  };
  for (int d = 0; d < D; ++d) {
    permute_real(fluid_.pos[d]);
    permute_real(fluid_.vel[d]);
    if (config_.integrator == Integrator::verlet) {
      permute_real(pos_saved_[d]);
      permute_real(vel_saved_[d]);
    }
  }
  permute_real(fluid_.rho);
  permute_real(fluid_.mass);
  if (config_.integrator == Integrator::verlet) permute_real(rho_saved_);
  {
    I.scratch_u16.resize(keep);
    for (size_t k = 0; k < keep; ++k) I.scratch_u16[k] = fluid_.material[I.sort_buf[k].second];
    fluid_.material.swap(I.scratch_u16);
    I.scratch_u32.resize(keep);
    for (size_t k = 0; k < keep; ++k) I.scratch_u32[k] = fluid_.tag[I.sort_buf[k].second];
    fluid_.tag.swap(I.scratch_u32);
    I.scratch_u32.resize(keep);
    for (size_t k = 0; k < keep; ++k) I.scratch_u32[k] = fluid_.id[I.sort_buf[k].second];
    fluid_.id.swap(I.scratch_u32);
  }

  // Fluid cells.
  I.fcell_key.clear();
  I.fcell_begin.clear();
  for (size_t k = 0; k < keep; ++k) {
    const uint64_t key = I.sort_buf[k].first;
    if (I.fcell_key.empty() || I.fcell_key.back() != key) {
      I.fcell_key.push_back(key);
      I.fcell_begin.push_back(static_cast<uint32_t>(k));
    }
  }
  I.fcell_begin.push_back(static_cast<uint32_t>(keep));
  const size_t ncells = I.fcell_key.size();
  constexpr int kNb = Impl::kNb;
  constexpr int kHalf = Impl::kHalf;
  constexpr int kCentre = kNb / 2;  // the cell's own column
  I.fnb_half.resize(ncells * kHalf);
  I.fnb_bound.resize(ncells * kNb);
  I.fnb_half_n.assign(ncells, 0);
  I.fnb_bound_n.assign(ncells, 0);
#pragma omp parallel
  {
    std::array<size_t, kNb> fhint{}, bhint{};
#pragma omp for schedule(static)
    for (size_t c = 0; c < ncells; ++c) {
      const auto cc = Impl::unpack(I.fcell_key[c]);
      int nf = 0, nbnd = 0;
      typename Impl::Block blk;
      // Column o has horizontal offsets (o % 5 - 2, o / 5 - 2): o > kCentre is the half after the own column.
      for (int o = kCentre; o < kNb; ++o)
        if (I.column(I.fcell_key, I.fcell_begin, cc, o, blk, fhint[o])) I.fnb_half[c * kHalf + nf++] = blk;
      for (int o = 0; o < kNb; ++o)
        if (I.column(I.bcell_key, I.bcell_begin, cc, o, blk, bhint[o])) I.fnb_bound[c * kNb + nbnd++] = blk;
      I.fnb_half_n[c] = static_cast<uint8_t>(nf);
      I.fnb_bound_n[c] = static_cast<uint8_t>(nbnd);
    }
  }

  // Boundary cells next to fluid: the only boundary particles that do work this step. Boundary blocks are
  // runs of whole boundary cells, so mark the cells each run covers.
  ++I.stamp;
  I.active_bcells.clear();
  for (size_t c = 0; c < ncells; ++c) {
    for (int k = 0; k < I.fnb_bound_n[c]; ++k) {
      const auto& blk = I.fnb_bound[c * kNb + k];
      for (uint32_t cb = blk.cell0; cb < blk.cell1; ++cb) {
        if (I.bcell_stamp[cb] != I.stamp) {
          I.bcell_stamp[cb] = I.stamp;
          I.active_bcells.push_back(static_cast<uint32_t>(cb));
        }
      }
    }
  }
  I.bslot.resize(boundary_.size());
  uint32_t slot = 0;
  for (uint32_t cb : I.active_bcells)
    for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) I.bslot[b] = slot++;
  I.active_boundary_count = slot;

  // Work arrays follow the (possibly smaller) particle count.
  for (int d = 0; d < D; ++d) acc_[d].resize(keep);
  drho_.resize(keep);
  pressure_.resize(keep);
  mu_eff_.resize(keep);
  shear_rate_.resize(keep);
  yield_pressure_.resize(keep);
  for (int d = 0; d < D; ++d) contact_normal_[d].assign(keep, 0);
  mu_wall_.resize(keep);
  zero_pressure_.resize(keep);
}

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

// Pair geometry of list entries [q0, q1) of a particle at x with density rho_i (no periodic axes): separations,
// r^2, r, inv = 1 / (r (r^2 + eta^2) (rho_i + rho_j)) and F. A vector loop (gathers).
template <int D, class Kernel>
void pair_geometry(const Kernel& kernel, const uint32_t* __restrict list, uint32_t q0, uint32_t q1,
                   const real* __restrict qa, const real* __restrict qb, const real* __restrict qc,
                   const real* __restrict rhoq, real xa, real xb, real xc, real rhoi, real eta2, real* __restrict da,
                   real* __restrict db, real* __restrict dc, real* __restrict r2o, real* __restrict ro,
                   real* __restrict invo, real* __restrict Fo) {
  for (uint32_t q = q0; q < q1; ++q) {
    const uint32_t j = list[q];
    const real a = xa - qa[j], b = xb - qb[j];
    real r2 = a * a + b * b;
    da[q] = a;
    db[q] = b;
    if constexpr (D == 3) {
      const real c = xc - qc[j];
      r2 += c * c;
      dc[q] = c;
    }
    const real r = std::sqrt(r2), e = r2 + eta2, rs = rhoi + rhoq[j];
    const real inv = 1.0 / (r * e * rs);
    r2o[q] = r2;
    ro[q] = r;
    invo[q] = inv;
    Fo[q] = kernel.grad_factor_in_support(r, inv * e * rs);
  }
}

// One particle's pair list, worked out before its force loop (see prepare() in evaluate).
template <int D>
struct PairGeometry {
  std::array<std::vector<real>, D> dx;
  std::vector<real> r2, r, inv, F;
  void ensure(size_t n) {
    if (r2.size() >= n) return;
    const size_t m = std::max<size_t>({n, 2 * r2.size(), 256});
    for (auto& v : dx) v.resize(m);
    r2.resize(m);
    r.resize(m);
    inv.resize(m);
    F.resize(m);
  }
};

}  // namespace

// The interaction kernels. Templated on the kernel and on whether the stress term exists, so the pair
// loops carry no runtime model switches.
//
// Pairs: each evaluation first lists, for every fluid particle i, its fluid neighbours j > i in the half
// stencil (the own column with higher indices, and the columns "after" it), so each fluid pair is listed
// once, then all its boundary neighbours. The listing test is branch-free. The passes then walk the lists and
// apply each pair's term to both particles (the terms are antisymmetric or symmetric in i and j); the j side
// and the boundary side go to per-thread accumulators, summed after the pass, so no two threads write the
// same memory and no pair is evaluated twice.
template <int D>
void Solver<D>::evaluate(bool compute_dt) {
  auto& I = *impl_;
  constexpr int kNb = Impl::kNb;
  constexpr int kHalf = Impl::kHalf;
  const size_t n = fluid_.size();
  const size_t ncells = I.fcell_key.size();
  const real h = config_.smoothing_length;
  const real c0 = config_.speed_of_sound;
  const real gam = config_.eos_gamma;
  const real eta2 = 0.01 * h * h;
  const real alpha = config_.artificial_viscosity;
  const bool ddt_on = config_.density_diffusion != DensityDiffusion::none && config_.density_diffusion_delta > 0;
  const real ddt_coef = ddt_on ? 2.0 * config_.density_diffusion_delta * h * c0 : 0.0;
  const bool fourtakas = config_.density_diffusion == DensityDiffusion::fourtakas;
  Vec<D> g;
  for (int d = 0; d < D; ++d) g[d] = config_.gravity[d];
  const real inv_c0_sq = 1.0 / (c0 * c0);
  const real contact2 = kWallContact * kWallContact * config_.dp * config_.dp;
  // Slip speed below which basal Coulomb friction is proportional to the slip (regularisation).
  const real v_slip = 0.01 * std::sqrt(9.81 * config_.dp);
  const int nthreads = omp_get_max_threads();

  bool viscous = false;
  for (const auto& r : rheologies_) viscous = viscous || !r->is_inviscid();

  // Equation of state (Tait), per material for fluid; boundary particles use the boundary density.
  std::vector<real> B(materials_.size()), rho0(materials_.size()), p_min(materials_.size()),
      wall_friction(materials_.size());
  for (size_t k = 0; k < materials_.size(); ++k) {
    rho0[k] = materials_[k].density;
    B[k] = c0 * c0 * rho0[k] / gam;
    // A cohesionless granular material carries no tension: without this floor a spreading sheet goes into
    // tension, clumps and sinks into the bed's lattice (docs/validation.md, "Thin sheets on terrain").
    p_min[k] = -rheologies_[k]->tensile_strength();
    wall_friction[k] = rheologies_[k]->wall_friction_coefficient();
  }
  const bool gamma7 = gam == 7.0;
  auto tait = [gamma7, gam](real rho, real r0, real b) {
    const real x = rho / r0;
    real xg;
    if (gamma7) {
      const real x2 = x * x;
      xg = x2 * x2 * x2 * x;
    } else {
      xg = std::pow(x, gam);
    }
    return b * (xg - 1.0);
  };
  I.vol.resize(n);
  I.pt.resize(n);
  I.inv_rho.resize(n);
  I.neighbour_pack.resize(Impl::kPackStride * n);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const int k = fluid_.material[i];
    const real r = fluid_.rho[i];
    pressure_[i] = std::max(tait(r, rho0[k], B[k]), p_min[k]);
    I.inv_rho[i] = 1.0 / r;
    I.vol[i] = fluid_.mass[i] * I.inv_rho[i];
    I.pt[i] = pressure_[i] * I.inv_rho[i] * I.inv_rho[i];
    real* pk = I.neighbour_pack.data() + Impl::kPackStride * i;
    for (int d = 0; d < D; ++d) pk[d] = fluid_.vel[d][i];
    pk[Impl::kPackRho] = r;
    pk[Impl::kPackVol] = I.vol[i];
    pk[Impl::kPackPt] = I.pt[i];
    pk[Impl::kPackPm] = pressure_[i];
    pk[Impl::kPackInvRho] = I.inv_rho[i];
  }
  const real rho0_b = config_.boundary_density;
  const real B_b = c0 * c0 * rho0_b / gam;
  const size_t nact = I.active_bcells.size();
  const size_t nslots = I.active_boundary_count;
  const bool extrapolated = config_.boundary_pressure == BoundaryPressure::extrapolated;
  if (!extrapolated) {
#pragma omp parallel for schedule(static)
    for (size_t a = 0; a < nact; ++a) {
      const uint32_t cb = I.active_bcells[a];
      for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b)
        boundary_pressure_[b] = tait(boundary_.rho[b], rho0_b, B_b);
    }
  }

  real max_acc = 0, max_visc_term = 0, max_nu = 0;

  I.list_buf.resize(nthreads);
  I.list_off.resize(n);
  I.list_nf.resize(n);
  I.list_nb.resize(n);
  I.list_thread.resize(n);
  I.acc_f.resize(nthreads);
  I.acc_b.resize(nthreads);
  I.bvol.resize(boundary_.size());
  I.bpt.resize(boundary_.size());

  // kViscous: the scene has a stress term (pass 1 measures the velocity gradient first); without one,
  // continuity and momentum share a single pass over the pairs.
  auto interact = [&]<bool kViscous>(auto kernel) {
    const real support2 = kernel.support() * kernel.support();
    // Raw pointers held in locals: the compiler need not reload them after every accumulator store.
    std::array<const real*, D> P, V, BP;
    for (int d = 0; d < D; ++d) {
      P[d] = fluid_.pos[d].data();
      V[d] = fluid_.vel[d].data();
      BP[d] = boundary_.pos[d].data();
    }
    const real* mass = fluid_.mass.data();
    const real* rho = fluid_.rho.data();
    const uint16_t* mat = fluid_.material.data();
    const real* press = pressure_.data();
    const real* bmass = boundary_.mass.data();
    const real* brho = boundary_.rho.data();
    const real* bpress = boundary_pressure_.data();
    const uint32_t* bslot = I.bslot.data();
    const real* vol = I.vol.data();
    const real* pt = I.pt.data();
    const real* inv_rho = I.inv_rho.data();
    const real* pack = I.neighbour_pack.data();
    constexpr int kPS = Impl::kPackStride, kPRho = Impl::kPackRho, kPVol = Impl::kPackVol, kPPt = Impl::kPackPt,
                  kPPm = Impl::kPackPm, kPInvRho = Impl::kPackInvRho;
    const real* bvol = I.bvol.data();
    const real* bpt = I.bpt.data();
    // Periodic axes: pair separations take the nearest image (the period is >= 5 h, so it is unique).
    const Vec<D> period = I.period;
    bool any_periodic = false;
    for (int d = 0; d < D; ++d) any_periodic = any_periodic || period[d] > 0;

    // Pair lists. The store is unconditional and the cursor advances by the test's outcome: no branch to
    // mispredict on the ~3/4 of candidates that fall outside the support.
#pragma omp parallel
    {
      const int t = omp_get_thread_num();
      auto& buf = I.list_buf[t];
      size_t pos = 0;
      std::vector<real> r2buf;
      // Distances of a contiguous run first (a vector loop), then the branch-free compaction.
      auto scan = [&](const std::array<const real*, D>& Q, const Vec<D>& xs, uint32_t j0, uint32_t j1) {
        if (j1 <= j0) return;
        const uint32_t m = j1 - j0;
        if (buf.size() < pos + m) buf.resize(std::max<size_t>(2 * buf.size(), pos + m + 1024));
        if (r2buf.size() < m) r2buf.resize(std::max<size_t>(m, 2 * r2buf.size()));
        real* __restrict r2s = r2buf.data();
        if constexpr (D == 3)
          distances_squared3(Q[0] + j0, Q[1] + j0, Q[2] + j0, xs[0], xs[1], xs[2], m, r2s);
        else
          distances_squared2(Q[0] + j0, Q[1] + j0, xs[0], xs[1], m, r2s);
        uint32_t* out = buf.data();
        for (uint32_t k = 0; k < m; ++k) {
          out[pos] = j0 + k;
          pos += (r2s[k] < support2) & (r2s[k] >= 1e-24);
        }
      };
#pragma omp for schedule(dynamic, 16)
      for (size_t c = 0; c < ncells; ++c) {
        for (uint32_t i = I.fcell_begin[c]; i < I.fcell_begin[c + 1]; ++i) {
          Vec<D> xi;
          for (int d = 0; d < D; ++d) xi[d] = P[d][i];
          const size_t start = pos;
          for (int k = 0; k < I.fnb_half_n[c]; ++k) {
            const auto& blk = I.fnb_half[c * kHalf + k];
            // Block 0 is the particle's own column: only the higher indices (the pair's other half is listed
            // by the lower-index particle).
            scan(P, xi - I.shifts[blk.shift], k == 0 ? i + 1 : blk.begin, blk.end);
          }
          const size_t nf = pos - start;
          for (int k = 0; k < I.fnb_bound_n[c]; ++k) {
            const auto& blk = I.fnb_bound[c * kNb + k];
            scan(BP, xi - I.shifts[blk.shift], blk.begin, blk.end);
          }
          I.list_thread[i] = static_cast<uint16_t>(t);
          I.list_off[i] = static_cast<uint32_t>(start);
          I.list_nf[i] = static_cast<uint32_t>(nf);
          I.list_nb[i] = static_cast<uint32_t>(pos - start - nf);
        }
      }
    }

    // Runs body(A, Bacc) in a parallel region in which each thread owns accumulators A (nf_fields values per
    // fluid particle, particle-major so one pair's updates share a cache line) and Bacc (nb_fields per active
    // boundary particle), zeroed; then, after the barrier, finish_fluid(sum, i) for every fluid particle with
    // sum(f, i) the total over threads, and finish_boundary(bsum, b, slot) for every active boundary particle.
    auto accumulate = [&](int nf_fields, int nb_fields, auto&& body, auto&& finish_fluid, auto&& finish_boundary) {
#pragma omp parallel reduction(max : max_acc, max_visc_term, max_nu)
      {
        const int t = omp_get_thread_num();
        const int T = omp_get_num_threads();
        auto& A = I.acc_f[t];
        auto& Bacc = I.acc_b[t];
        A.assign(static_cast<size_t>(nf_fields) * n, 0.0);
        Bacc.assign(static_cast<size_t>(nb_fields) * nslots, 0.0);
        body(A.data(), Bacc.data());
        // (the worksharing loop in body ends with a barrier: every thread's accumulators are complete)
        auto fsum = [&](int f, size_t i) {
          real s = 0;
          for (int u = 0; u < T; ++u) s += I.acc_f[u][i * nf_fields + f];
          return s;
        };
        auto bsum = [&](int f, size_t q) {
          real s = 0;
          for (int u = 0; u < T; ++u) s += I.acc_b[u][q * nb_fields + f];
          return s;
        };
#pragma omp for schedule(static)
        for (size_t i = 0; i < n; ++i) finish_fluid(fsum, i);
        if (nb_fields > 0) {
#pragma omp for schedule(static)
          for (size_t a = 0; a < nact; ++a) {
            const uint32_t cb = I.active_bcells[a];
            for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) finish_boundary(bsum, b, bslot[b]);
          }
        }
      }
    };
    auto list_of = [&](uint32_t i) { return I.list_buf[I.list_thread[i]].data() + I.list_off[i]; };
    // The fluid particles, cell by cell, shared among the threads of the enclosing parallel region.
    auto for_each_fluid = [&](auto&& f) {
#pragma omp for schedule(dynamic, 16)
      for (size_t c = 0; c < ncells; ++c)
        for (uint32_t i = I.fcell_begin[c]; i < I.fcell_begin[c + 1]; ++i) f(i);
    };
    auto state_of = [&](uint32_t i, Vec<D>& xi, Vec<D>& vi) {
      for (int d = 0; d < D; ++d) {
        xi[d] = P[d][i];
        vi[d] = V[d][i];
      }
    };

    // Extrapolated boundary pressure (Adami et al. 2012 with the hydrostatic term):
    // p_b = sum_f (p_f + rho_f g.(x_b - x_f)) W_bf / sum_f W_bf, clamped at 0; density from the EOS.
    if (extrapolated) {
      accumulate(
          0, 2,
          [&](real*, real* Bacc) {
#pragma omp for schedule(dynamic, 16)
            for (size_t c = 0; c < ncells; ++c) {
              for (uint32_t i = I.fcell_begin[c]; i < I.fcell_begin[c + 1]; ++i) {
                const uint32_t* L = list_of(i) + I.list_nf[i];
                for (uint32_t q = 0; q < I.list_nb[i]; ++q) {
                  const uint32_t b = L[q];
                  real r2 = 0, gdx = 0;
                  for (int d = 0; d < D; ++d) {
                    // x_b - x_f up to the periodic image: the same as -(x_i - x_b) from the fluid's side.
                    real dxd = BP[d][b] - P[d][i];
                    if (any_periodic && period[d] > 0) dxd -= period[d] * std::round(dxd / period[d]);
                    r2 += dxd * dxd;
                    gdx += g[d] * dxd;
                  }
                  const real w = kernel.W(std::sqrt(r2));
                  Bacc[2 * bslot[b]] += w;
                  Bacc[2 * bslot[b] + 1] += (press[i] + rho[i] * gdx) * w;
                }
              }
            }
          },
          [](auto&&, size_t) {},
          [&](auto&& bsum, uint32_t b, uint32_t s) {
            const real sw = bsum(0, s), spw = bsum(1, s);
            const real pb = sw > 0 ? std::max(spw / sw, 0.0) : 0.0;
            boundary_pressure_[b] = pb;
            boundary_.rho[b] = rho0_b * std::pow(1.0 + pb / B_b, 1.0 / gam);
          });
    }

#pragma omp parallel for schedule(static)
    for (size_t a = 0; a < nact; ++a) {
      const uint32_t cb = I.active_bcells[a];
      for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) {
        I.bvol[b] = bmass[b] / brho[b];
        I.bpt[b] = bpress[b] / (brho[b] * brho[b]);
      }
    }

    // Pair geometry in two stages. prepare() runs over a particle's whole list first: separations (periodic
    // image), r, F and one reciprocal per pair, inv = 1 / (r (r^2 + eta^2) (rho_i + rho_j)), from which 1/r,
    // 1/(r^2 + eta^2) and 1/(rho_i + rho_j) follow by products. A short loop of independent square roots and
    // divisions keeps the pipelines full; inside the long force loop their latency stalled it.
    auto prepare = [&](PairGeometry<D>& G, const Vec<D>& xi, real rhoi, const uint32_t* list, uint32_t nfl,
                       uint32_t nbl) {
      G.ensure(nfl + nbl);
      // Restrict-qualified locals: the stores cannot alias the loads, so the loop vectorises (gathers).
      real* __restrict gdx[3] = {G.dx[0].data(), G.dx[D > 1 ? 1 : 0].data(), G.dx[D > 2 ? 2 : 0].data()};
      real* __restrict gr2 = G.r2.data();
      real* __restrict gr = G.r.data();
      real* __restrict ginv = G.inv.data();
      real* __restrict gF = G.F.data();
      auto stage = [&]<bool kPeriodic>(uint32_t q0, uint32_t q1, const std::array<const real*, D> Q,
                                       const real* __restrict rhoQ) {
        const Vec<D> x = xi;
        for (uint32_t q = q0; q < q1; ++q) {
          const uint32_t j = list[q];
          real r2 = 0;
          for (int d = 0; d < D; ++d) {
            real dxd = x[d] - Q[d][j];
            if constexpr (kPeriodic)
              if (period[d] > 0) dxd -= period[d] * std::round(dxd / period[d]);
            gdx[d][q] = dxd;
            r2 += dxd * dxd;
          }
          const real r = std::sqrt(r2), e = r2 + eta2, rs = rhoi + rhoQ[j];
          const real inv = 1.0 / (r * e * rs);
          gr2[q] = r2;
          gr[q] = r;
          ginv[q] = inv;
          gF[q] = kernel.grad_factor_in_support(r, inv * e * rs);
        }
      };
      if (any_periodic) {
        stage.template operator()<true>(0, nfl, P, rho);
        stage.template operator()<true>(nfl, nfl + nbl, BP, brho);
      } else {
        const real xc = D == 3 ? xi[D - 1] : 0.0;
        pair_geometry<D>(kernel, list, 0, nfl, P[0], P[1], P[D - 1], rho, xi[0], xi[1], xc, rhoi, eta2, gdx[0],
                         gdx[1], gdx[2], gr2, gr, ginv, gF);
        pair_geometry<D>(kernel, list, nfl, nfl + nbl, BP[0], BP[1], BP[D - 1], brho, xi[0], xi[1], xc, rhoi, eta2,
                         gdx[0], gdx[1], gdx[2], gr2, gr, ginv, gF);
      }
    };
    // Entry q of the list: dx = x_i - x_j, r2, v_ij and v_ij . dx (fluid j; a wall has v = 0).
    auto fluid_at = [&](const PairGeometry<D>& G, uint32_t q, const Vec<D>& vi, const real* pk, Vec<D>& dx, Vec<D>& vij,
                        real& vdotdx) {
      vdotdx = 0;
      for (int d = 0; d < D; ++d) {
        dx[d] = G.dx[d][q];
        vij[d] = vi[d] - pk[d];
        vdotdx += vij[d] * dx[d];
      }
      return G.r2[q];
    };
    auto wall_at = [&](const PairGeometry<D>& G, uint32_t q, const Vec<D>& vi, Vec<D>& dx, real& vdotdx) {
      vdotdx = 0;
      for (int d = 0; d < D; ++d) {
        dx[d] = G.dx[d][q];
        vdotdx += vi[d] * dx[d];
      }
      return G.r2[q];
    };
    // Density diffusion of one same-material fluid pair: the term for i is -dr F V_j, for j +dr F V_i.
    // Fourtakas et al. (2019) subtract the hydrostatic density difference, linearised:
    // rho0 g.(x_j - x_i) / c0^2 (exact to O((g h / c0^2)^2)).
    auto diffusion_dr = [&](real rhoi, real rhoj, int mi, const Vec<D>& dx) {
      real dr = rhoj - rhoi;
      if (fourtakas) dr += rho0[mi] * g.dot(dx) * inv_c0_sq;
      return dr;
    };

    constexpr int kDiv = 0, kDiff = 1;
    if constexpr (kViscous) {
      // Pass 1: continuity with density diffusion, the velocity gradient L = -sum V_j v_ij (x) grad W, the
      // kernel-averaged pressure for the yield stress, and the boundary's DBC continuity.
      constexpr int kPw = 2, kWw = 3, kL = 4;  // L: D*D fields, row-major
      constexpr int kS1 = kL + D * D;
      accumulate(
          kS1, 1,
          [&](real* A, real* Bacc) {
            PairGeometry<D> G;
            for_each_fluid([&](uint32_t i) {
              Vec<D> xi, vi;
              state_of(i, xi, vi);
              const real rhoi = rho[i], Vi = vol[i], pi = press[i];
              const int mi = mat[i];
              real div = 0, diff = 0, pw = 0, ww = 0;
              Mat<D> L = Mat<D>::Zero();
              const uint32_t* list = list_of(i);
              const uint32_t nfl = I.list_nf[i], nbl = I.list_nb[i];
              prepare(G, xi, rhoi, list, nfl, nbl);
              for (uint32_t q = 0; q < nfl; ++q) {
                const uint32_t j = list[q];
                Vec<D> dx, vij;
                real vdotdx;
                const real* pk = pack + kPS * j;
                fluid_at(G, q, vi, pk, dx, vij, vdotdx);
                const real F = G.F[q], W = kernel.W(G.r[q]);
                const real Vj = pk[kPVol];
                div += Vj * F * vdotdx;
                A[j * kS1 + kDiv] += Vi * F * vdotdx;
                if (ddt_coef > 0 && mat[j] == mi) {
                  const real dr = diffusion_dr(rhoi, pk[kPRho], mi, dx);
                  diff -= dr * F * Vj;
                  A[j * kS1 + kDiff] += dr * F * Vi;
                }
                // L_i -= V_j F v_ij dx^T and L_j -= V_i F v_ji dx_ji^T = V_i F v_ij dx^T.
                for (int a = 0; a < D; ++a)
                  for (int b = 0; b < D; ++b) {
                    const real vd = F * vij[a] * dx[b];
                    L(a, b) -= Vj * vd;
                    A[j * kS1 + (kL + a * D + b)] -= Vi * vd;
                  }
                pw += Vj * W * pk[kPPm];
                ww += Vj * W;
                A[j * kS1 + kPw] += Vi * W * pi;
                A[j * kS1 + kWw] += Vi * W;
              }
              for (uint32_t q = nfl; q < nfl + nbl; ++q) {
                const uint32_t b = list[q];
                Vec<D> dx;
                real vdotdx;
                wall_at(G, q, vi, dx, vdotdx);
                const real F = G.F[q];
                div += bvol[b] * F * vdotdx;
                // No-slip wall, v_b = 0: the same wall velocity the viscous force of pass 2 acts against. (A
                // mirrored v_b = -v_i, needed by the former stress-divergence force for energy consistency,
                // overestimates the wall shear rate: the Bingham Poiseuille plug then ran 9 % fast.)
                L.noalias() -= (bvol[b] * F) * vi * dx.transpose();
                // DBC continuity of b, drho_b/dt = rho_b sum V_f (0 - v_f) . grad_b W = rho_b sum V_f F v_f . dx.
                Bacc[bslot[b]] += Vi * F * vdotdx;
              }
              A[i * kS1 + kDiv] += div;
              A[i * kS1 + kDiff] += diff;
              A[i * kS1 + kPw] += pw;
              A[i * kS1 + kWw] += ww;
              for (int a = 0; a < D; ++a)
                for (int b = 0; b < D; ++b) A[i * kS1 + (kL + a * D + b)] += L(a, b);
            });
          },
          [&](auto&& sum, size_t i) {
            // The kernel-averaged pressure includes the particle itself.
            const real self = mass[i] / rho[i] * kernel.W(0);
            yield_pressure_[i] = (sum(kPw, i) + self * press[i]) / (sum(kWw, i) + self);
            drho_[i] = rho[i] * sum(kDiv, i) + ddt_coef * sum(kDiff, i);
            Mat<D> L;
            for (int a = 0; a < D; ++a)
              for (int b = 0; b < D; ++b) L(a, b) = sum(kL + a * D + b, i);
            // Strain rate D = sym(L); deviator with the 3D trace (plane strain in 2D).
            const Mat<D> Ds = 0.5 * (L + L.transpose());
            const real tr3 = Ds.trace() / 3.0;
            Mat<D> Dd = Ds;
            for (int d = 0; d < D; ++d) Dd(d, d) -= tr3;
            real dd = Dd.squaredNorm();
            if constexpr (D == 2) dd += tr3 * tr3;  // the zz component of the plane-strain deviator
            shear_rate_[i] = std::max(std::sqrt(2.0 * dd), config_.shear_rate_floor);
          },
          [&](auto&& bsum, uint32_t b, uint32_t s) { boundary_drho_[b] = brho[b] * bsum(0, s); });

      // Rheology: one call per material batch.
      if (materials_.size() == 1) {
        rheologies_[0]->effective_viscosity(shear_rate_, yield_pressure_, mu_eff_);
        if (wall_friction[0] > 0) {
          std::fill(zero_pressure_.begin(), zero_pressure_.end(), real(0));
          rheologies_[0]->effective_viscosity(shear_rate_, zero_pressure_, mu_wall_);
        }
      } else {
        for (size_t k = 0; k < materials_.size(); ++k) {
          std::vector<uint32_t> idx;
          for (size_t i = 0; i < n; ++i)
            if (fluid_.material[i] == k) idx.push_back(static_cast<uint32_t>(i));
          std::vector<real> gd(idx.size()), p(idx.size()), mu(idx.size());
          for (size_t q = 0; q < idx.size(); ++q) {
            gd[q] = shear_rate_[idx[q]];
            p[q] = yield_pressure_[idx[q]];
          }
          rheologies_[k]->effective_viscosity(gd, p, mu);
          for (size_t q = 0; q < idx.size(); ++q) mu_eff_[idx[q]] = mu[q];
          if (wall_friction[k] > 0) {
            std::fill(p.begin(), p.end(), real(0));
            rheologies_[k]->effective_viscosity(gd, p, mu);
            for (size_t q = 0; q < idx.size(); ++q) mu_wall_[idx[q]] = mu[q];
          }
        }
      }
      const real cap = max_viscosity_;
#pragma omp parallel for schedule(static) reduction(max : max_nu)
      for (size_t i = 0; i < n; ++i) {
        const real mu = std::min(mu_eff_[i], cap);
        mu_eff_[i] = mu;
        mu_wall_[i] = wall_friction[fluid_.material[i]] > 0 ? std::min(mu_wall_[i], cap) : mu;
        max_nu = std::max(max_nu, mu / rho[i]);
        I.neighbour_pack[Impl::kPackStride * i + Impl::kPackPm] = mu;  // pass 2 reads mu_eff where pass 1 read p
      }
    }

    // Pass 2: momentum (pressure, artificial viscosity, rheology stress, gravity); in inviscid scenes also
    // continuity and the boundary's DBC continuity. The rheology stress acts through the Morris et al. (1997)
    // viscous operator with each particle's capped mu_eff from pass 1 (the same for every rheology): a one-step
    // Laplacian stencil, with no odd-even null mode, unlike the divergence of tau = 2 mu_eff D' built from the
    // SPH velocity gradient (alternate particle rows slid past each other). It approximates div(mu_eff grad v)
    // and drops the grad(mu_eff) . (grad v)^T part of div(2 mu_eff D'), which vanishes in simple shear
    // (docs/design.md). Pairwise symmetric and v_ij-parallel, so it conserves momentum and can only dissipate
    // energy.
    constexpr int kAcc = kViscous ? 0 : 2;  // first of D acceleration fields (inviscid: after div and diff)
    constexpr int kS2 = kAcc + D;
    accumulate(
        kS2, kViscous ? 0 : 1,
        [&](real* A, real* Bacc) {
            PairGeometry<D> G;
          for_each_fluid([&](uint32_t i) {
            Vec<D> xi, vi;
            state_of(i, xi, vi);
            const real rhoi = rho[i], mi_mass = mass[i], Vi = vol[i];
            const int mi = mat[i];
            const real pi_term = pt[i];
            const real mui = kViscous ? mu_eff_[i] : 0.0;
            const real mu_wall_i = kViscous ? mu_wall_[i] : 0.0;
            const real friction_i = kViscous ? wall_friction[mi] : 0.0;
            Vec<D> a = Vec<D>::Zero();
            Vec<D> a_wall_push = Vec<D>::Zero();  // the walls' pressure force on the particle, per unit mass
            bool contact = false;                 // closer than kWallContact dp to a wall particle
            Vec<D> wall_normal = Vec<D>::Zero();  // -sum_b V_b grad W: points away from the wall
            real visc_max = 0, div = 0, diff = 0;
            const uint32_t* list = list_of(i);
            const uint32_t nfl = I.list_nf[i], nbl = I.list_nb[i];
            prepare(G, xi, rhoi, list, nfl, nbl);
            for (uint32_t q = 0; q < nfl; ++q) {
              const uint32_t j = list[q];
              Vec<D> dx, vij;
              real vdotdx;
              const real* pk = pack + kPS * j;
              const real r2 = fluid_at(G, q, vi, pk, dx, vij, vdotdx);
              const real rhoj = pk[kPRho], Vj = pk[kPVol], mj = Vj * rhoj;
              const real r = G.r[q], e = r2 + eta2, rs = rhoi + rhoj, inv = G.inv[q];
              const real inv_e = inv * r * rs;
              const real F = G.F[q];
              if constexpr (!kViscous) {
                div += Vj * F * vdotdx;
                A[j * kS2 + kDiv] += Vi * F * vdotdx;
                if (ddt_coef > 0 && mat[j] == mi) {
                  const real dr = diffusion_dr(rhoi, rhoj, mi, dx);
                  diff -= dr * F * Vj;
                  A[j * kS2 + kDiff] += dr * F * Vi;
                }
              }
              real pterm = pi_term + pk[kPPt];
              const real mu_ij = h * vdotdx * inv_e;
              visc_max = std::max(visc_max, std::abs(mu_ij));
              // Monaghan: approaching pairs only, over the mean density; a select, not a branch (the sign is as
              // good as random).
              if (alpha > 0) pterm -= 2.0 * alpha * c0 * std::min(mu_ij, real(0)) * (inv * r * e);
              // a_i = m_j s, a_j = -m_i s with s = -pterm F dx + (Morris) visc v_ij: antisymmetric in i, j.
              Vec<D> s = (-pterm * F) * dx;
              if constexpr (kViscous) {
                // Morris et al. (1997): (mu_i + mu_j) / (rho_i rho_j) (r_ij . grad W) / (r^2 + eta^2) v_ij,
                // r_ij . grad W = F r^2 (F < 0: the pair force opposes v_ij).
                s += ((mui + pk[kPPm]) * inv_rho[i] * pk[kPInvRho] * F * r2 * inv_e) * vij;
              }
              a += mj * s;
              for (int d = 0; d < D; ++d) A[j * kS2 + (kAcc + d)] -= mi_mass * s[d];
            }
            // Boundary neighbours: no-slip (v_b = 0, so v_ij = v_i), DBC or extrapolated pressure; the wall
            // particle takes the fluid particle's viscosity (mu_b = mu_i).
            for (uint32_t q = nfl; q < nfl + nbl; ++q) {
              const uint32_t b = list[q];
              Vec<D> dx;
              real vdotdx;
              const real r2 = wall_at(G, q, vi, dx, vdotdx);
              const real rhob = brho[b], mb = bmass[b];
              const real r = G.r[q], e = r2 + eta2, rs = rhoi + rhob, inv = G.inv[q];
              const real inv_e = inv * r * rs;
              const real F = G.F[q];
              if constexpr (!kViscous) {
                div += bvol[b] * F * vdotdx;
                Bacc[bslot[b]] += Vi * F * vdotdx;  // DBC continuity of b (see pass 1)
              }
              // A wall pushes and never pulls: where a fluid particle's pressure is negative (a liquid may
              // carry tension) the pair term would draw it into the wall's particle lattice.
              real pterm = std::max(pi_term + bpt[b], real(0));
              const real mu_ij = h * vdotdx * inv_e;
              visc_max = std::max(visc_max, std::abs(mu_ij));
              if (alpha > 0) pterm -= 2.0 * alpha * c0 * std::min(mu_ij, real(0)) * (inv * r * e);
              const Vec<D> push = (-mb * pterm * F) * dx;
              a += push;
              a_wall_push += push;
              if constexpr (kViscous) a += (mb * 2.0 * mu_wall_i * inv_rho[i] / rhob * F * r2 * inv_e) * vi;
              contact = contact || r2 < contact2;
              wall_normal -= (bvol[b] * F) * dx;
            }
            if constexpr (kViscous) {
              // Basal friction (friction rheologies): Coulomb against the wall's normal push N, along the
              // tangential velocity, smoothed over a slip speed v_slip so a resting particle is not chattered
              // by sign flips.
              const real push = a_wall_push.norm();
              if (friction_i > 0 && push > 0) {
                const Vec<D> nrm = a_wall_push / push;
                const Vec<D> vt = vi - vi.dot(nrm) * nrm;
                const real vts = vt.norm();
                if (vts > 0) a -= (friction_i * push * -std::expm1(-vts / v_slip) / vts) * vt;
              }
            }
            {
              const real nn = wall_normal.norm();
              for (int d = 0; d < D; ++d) contact_normal_[d][i] = contact && nn > 0 ? wall_normal[d] / nn : 0;
            }
            if constexpr (!kViscous) {
              A[i * kS2 + kDiv] += div;
              A[i * kS2 + kDiff] += diff;
            }
            for (int d = 0; d < D; ++d) A[i * kS2 + (kAcc + d)] += a[d];
            max_visc_term = std::max(max_visc_term, visc_max);
          });
        },
        [&](auto&& sum, size_t i) {
          Vec<D> a;
          for (int d = 0; d < D; ++d) a[d] = sum(kAcc + d, i) + g[d];
          for (int d = 0; d < D; ++d) acc_[d][i] = a[d];
          max_acc = std::max(max_acc, a.squaredNorm());
          if constexpr (!kViscous) drho_[i] = rho[i] * sum(kDiv, i) + ddt_coef * sum(kDiff, i);
        },
        [&](auto&& bsum, uint32_t b, uint32_t s) {
          if constexpr (!kViscous) boundary_drho_[b] = brho[b] * bsum(0, s);
        });
  };

  with_kernel<D>(config_.kernel, h, [&](auto kernel) {
    if (viscous)
      interact.template operator()<true>(kernel);
    else
      interact.template operator()<false>(kernel);
  });
  max_acc = std::sqrt(max_acc);
  // Inlet buffers move at their inlet's velocity with a fixed density: no rates, no wall contact.
  if (!inlets_.empty()) {
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      if (!is_inlet_buffer(fluid_.tag[i])) continue;
      for (int d = 0; d < D; ++d) acc_[d][i] = 0, contact_normal_[d][i] = 0;
      drho_[i] = 0;
    }
  }

  stats_.active_boundary = 0;
  for (uint32_t cb : I.active_bcells) stats_.active_boundary += I.bcell_begin[cb + 1] - I.bcell_begin[cb];

  if (compute_dt) {
    // Monaghan & Kos (1999), thesis eq. 2.27, plus the viscous limit with the capped mu_eff.
    stats_.dt_force = max_acc > 0 ? std::sqrt(h / max_acc) : 1e300;
    stats_.dt_acoustic = h / (c0 + max_visc_term);
    stats_.dt_viscous = max_nu > 0 ? 0.125 * h * h / max_nu : 1e300;
    stats_.dt = std::min(config_.cfl * std::min(stats_.dt_force, stats_.dt_acoustic), stats_.dt_viscous);
    stats_.max_effective_viscosity = 0;
    if (viscous)
      for (size_t i = 0; i < n; ++i) stats_.max_effective_viscosity = std::max(stats_.max_effective_viscosity, mu_eff_[i]);
    if (!(stats_.dt >= config_.min_dt)) {
      std::ostringstream s;
      s << fmt_time(time_) << ": time step " << stats_.dt << " s fell below the floor " << config_.min_dt
        << " s (force limit " << stats_.dt_force << " s, acoustic " << stats_.dt_acoustic << " s, viscous "
        << stats_.dt_viscous << " s)";
      throw SimulationError(s.str(), SimulationError::Cause::dt_floor);
    }
  }
}

template <int D>
void Solver<D>::evaluate_rates() {
  sort_and_build_cells();
  evaluate(false);
}

template <int D>
const StepStats& Solver<D>::step() {
  auto& I = *impl_;
  sort_and_build_cells();
  if (!inlets_.empty()) impose_inlet_state();
  evaluate(true);
  const real dt = stats_.dt;
  const size_t n = fluid_.size();
  const real rho0_b = config_.boundary_density;
  // Density floor (config_.density_floor): the density at which the equation of state reaches the
  // material's tension floor (rho0 for a cohesionless material, whose pressure is floored at 0; none for a
  // liquid). Below it the pressure no longer changes, so nothing holds the continuity density: it drifts far
  // under rho0 while particles clump (0.3-0.5 dp apart), and the inflated volumes m/rho can make density
  // diffusion and the viscous term unstable (flume C6 at dp 0.04 m blew up at t = 3.48 s without it). The
  // walls' density has the same floor at their reference density, always.
  std::vector<real> rho_floor(materials_.size(), 0.0);
  if (config_.density_floor) {
    for (size_t k = 0; k < materials_.size(); ++k) {
      const real B = config_.speed_of_sound * config_.speed_of_sound * materials_[k].density / config_.eos_gamma;
      const real p_min = -rheologies_[k]->tensile_strength();
      if (p_min > -B)
        rho_floor[k] = (1.0 - config_.max_dilatancy) * materials_[k].density * std::pow(1.0 + p_min / B, 1.0 / config_.eos_gamma);
    }
  }
  const real* rho_floor_of = rho_floor.data();
  auto for_active_boundary = [&](auto&& f) {
#pragma omp parallel for schedule(static)
    for (size_t a = 0; a < I.active_bcells.size(); ++a) {
      const uint32_t cb = I.active_bcells[a];
      for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) f(b);
    }
  };

  // A particle in contact with a wall loses the velocity component that takes it further in (an inelastic
  // contact: it never adds energy). The wall pressure holds a resting sheet but does not grow as a particle
  // closes in: without this, lone particles went 1 dp under the Jacksboro terrain. The normal impulse taken
  // is part of the wall's normal force, so a friction material's Coulomb friction acts on it too: the
  // tangential speed drops by up to mu_wall |v_n| (never reversing). Without it a lone particle whose weight
  // the contact partly carried slid 7 % past the Coulomb distance, and the column collapse's one-particle
  // front sheet 0.09 m farther (docs/design.md).
  std::vector<real> contact_friction(materials_.size());
  for (size_t k = 0; k < materials_.size(); ++k) contact_friction[k] = rheologies_[k]->wall_friction_coefficient();
  const real* contact_friction_of = contact_friction.data();
  auto stop_wall_approach = [&](size_t i) {
    real vn = 0;
    for (int d = 0; d < D; ++d) vn += fluid_.vel[d][i] * contact_normal_[d][i];
    if (vn >= 0) return;
    real vt2 = 0;
    for (int d = 0; d < D; ++d) {
      fluid_.vel[d][i] -= vn * contact_normal_[d][i];
      vt2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    }
    const real mu = contact_friction_of[fluid_.material[i]];
    if (mu > 0 && vt2 > 0) {
      const real keep = std::max(real(0), 1 + mu * vn / std::sqrt(vt2));
      for (int d = 0; d < D; ++d) fluid_.vel[d][i] *= keep;
    }
  };

  if (config_.integrator == Integrator::symplectic) {
    // Predictor (thesis eq. 2.25).
    const real hdt = 0.5 * dt;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      for (int d = 0; d < D; ++d) {
        pos_saved_[d][i] = fluid_.pos[d][i];
        vel_saved_[d][i] = fluid_.vel[d][i];
        fluid_.pos[d][i] += hdt * fluid_.vel[d][i];
        fluid_.vel[d][i] += hdt * acc_[d][i];
      }
      rho_saved_[i] = fluid_.rho[i];
      fluid_.rho[i] = std::max(rho_floor_of[fluid_.material[i]], fluid_.rho[i] + hdt * drho_[i]);
    }
    for_active_boundary([&](uint32_t b) {
      boundary_rho_saved_[b] = boundary_.rho[b];
      boundary_.rho[b] = std::max(rho0_b, boundary_.rho[b] + hdt * boundary_drho_[b]);
    });
    evaluate(false);
    // Corrector (thesis eq. 2.26).
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      for (int d = 0; d < D; ++d) {
        fluid_.vel[d][i] = vel_saved_[d][i] + dt * acc_[d][i];
      }
      stop_wall_approach(i);
      for (int d = 0; d < D; ++d) fluid_.pos[d][i] = pos_saved_[d][i] + dt * 0.5 * (fluid_.vel[d][i] + vel_saved_[d][i]);
      const real eps = -drho_[i] / fluid_.rho[i] * dt;
      fluid_.rho[i] = std::max(rho_floor_of[fluid_.material[i]], rho_saved_[i] * (2.0 - eps) / (2.0 + eps));
    }
    for_active_boundary([&](uint32_t b) {
      const real eps = -boundary_drho_[b] / boundary_.rho[b] * dt;
      boundary_.rho[b] = std::max(rho0_b, boundary_rho_saved_[b] * (2.0 - eps) / (2.0 + eps));
    });
  } else {
    // Verlet (thesis eq. 2.23-2.24): the saved arrays hold the values at n-1.
    const bool euler = config_.verlet_reset_steps > 0 && (steps_ + 1) % config_.verlet_reset_steps == 0;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      for (int d = 0; d < D; ++d) {
        const real v = fluid_.vel[d][i];
        const real v_new = euler ? v + dt * acc_[d][i] : vel_saved_[d][i] + 2.0 * dt * acc_[d][i];
        fluid_.pos[d][i] += dt * v + 0.5 * dt * dt * acc_[d][i];
        vel_saved_[d][i] = v;
        fluid_.vel[d][i] = v_new;
      }
      stop_wall_approach(i);
      const real r = fluid_.rho[i];
      fluid_.rho[i] = std::max(rho_floor_of[fluid_.material[i]], euler ? r + dt * drho_[i] : rho_saved_[i] + 2.0 * dt * drho_[i]);
      rho_saved_[i] = r;
    }
    for_active_boundary([&](uint32_t b) {
      const real r = boundary_.rho[b];
      boundary_.rho[b] =
          std::max(rho0_b, euler ? r + dt * boundary_drho_[b] : boundary_rho_saved_[b] + 2.0 * dt * boundary_drho_[b]);
      boundary_rho_saved_[b] = r;
    });
  }

  time_ += dt;
  ++steps_;
  min_dt_seen_ = std::min(min_dt_seen_, dt);
  if (!inlets_.empty()) advance_inlets();
  check_state();
  return stats_;
}

// Guards: non-finite values, leaks through walls or closed domain faces. Also tracks the Mach number.
template <int D>
void Solver<D>::check_state() {
  const size_t n = fluid_.size();
  long bad = std::numeric_limits<long>::max();
  real vmax2 = 0;
#pragma omp parallel for reduction(min : bad) reduction(max : vmax2)
  for (size_t i = 0; i < n; ++i) {
    bool ok = std::isfinite(fluid_.rho[i]);
    real v2 = 0;
    for (int d = 0; d < D; ++d) {
      ok = ok && std::isfinite(fluid_.pos[d][i]) && std::isfinite(fluid_.vel[d][i]);
      v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    }
    if (!ok) bad = std::min(bad, static_cast<long>(i));
    vmax2 = std::max(vmax2, v2);
  }
  if (bad != std::numeric_limits<long>::max()) {
    const size_t i = static_cast<size_t>(bad);
    std::string what = !std::isfinite(fluid_.rho[i]) ? "density" : "velocity";
    for (int d = 0; d < D; ++d)
      if (!std::isfinite(fluid_.pos[d][i])) what = "position";
    std::ostringstream s;
    s << fmt_time(time_) << ": fluid particle " << fluid_.id[i] << " has a non-finite " << what << " (step "
      << steps_ << ", dt " << stats_.dt << " s)";
    throw SimulationError(s.str(), SimulationError::Cause::non_finite);
  }
  stats_.max_speed = std::sqrt(vmax2);
  max_mach_ = std::max(max_mach_, stats_.max_speed / config_.speed_of_sound);

  long leak = std::numeric_limits<long>::max();
  int leak_region = -1;
  // Leak regions with their axes worked out once, not per particle.
  struct Region {
    Vec<D> origin, size;
    std::array<Vec<D>, D> axis;
    bool contains(const Vec<D>& p) const {
      const Vec<D> r = p - origin;
      for (int d = 0; d < D; ++d) {
        const real l = r.dot(axis[d]);
        if (l < 0.0 || l > size[d]) return false;
      }
      return true;
    }
  };
  std::vector<Region> regions;
  for (const auto& r : leak_regions_) {
    Region q{r.box.origin, r.box.size, {}};
    for (int d = 0; d < D; ++d) q.axis[d] = r.box.axis(d);
    regions.push_back(q);
  }
  size_t leaked = 0;
#pragma omp parallel for reduction(min : leak) reduction(+ : leaked)
  for (size_t i = 0; i < n; ++i) {
    if (is_inlet_buffer(fluid_.tag[i])) continue;  // moved by their inlet, checked when it is built
    const Vec<D> p = fluid_.position(i);
    bool out = false;
    for (int d = 0; d < D; ++d) {
      if (config_.periodic[d] || d == D - 1) continue;  // the vertical top is open; the bottom is a wall
      out = out || (p[d] < config_.domain_min[d] && !config_.outflow[d][0]) ||
            (p[d] > config_.domain_max[d] && !config_.outflow[d][1]);
    }
    out = out || (!config_.periodic[D - 1] && p[D - 1] < config_.domain_min[D - 1] && !config_.outflow[D - 1][0]);
    for (const auto& r : regions) out = out || r.contains(p);
    if (out) {
      leak = std::min(leak, static_cast<long>(i));
      ++leaked;
    }
  }
  if (leak != std::numeric_limits<long>::max()) {
    const size_t i = static_cast<size_t>(leak);
    const Vec<D> p = fluid_.position(i);
    for (size_t k = 0; k < leak_regions_.size(); ++k)
      if (leak_regions_[k].contains(p)) leak_region = static_cast<int>(k);
    std::ostringstream s;
    s << fmt_time(time_) << ": fluid particle " << fluid_.id[i] << " leaked through ";
    if (leak_region >= 0)
      s << "boundary tag " << leak_regions_[leak_region].tag;
    else
      s << "a closed domain face";
    s << " at position (";
    for (int d = 0; d < D; ++d) s << (d ? ", " : "") << p[d];
    s << ") m";
    if (leaked > 1) s << " (" << leaked << " particles in all)";
    throw SimulationError(s.str(), SimulationError::Cause::leak, leaked);
  }
}

// Inlets ------------------------------------------------------------------------------------------------

int inlet_buffer_layers(const SolverConfig& c) {
  return static_cast<int>(std::ceil(2 * c.smoothing_length / c.dp - 1e-9)) + 1;
}

namespace {
// The coordinates of the opening, in axis order: 2D: z; 3D: the other horizontal axis, then z.
template <int D>
std::array<int, D - 1> opening_axes(int axis) {
  std::array<int, D - 1> a{};
  int k = 0;
  for (int d = 0; d < D; ++d)
    if (d != axis) a[k++] = d;
  return a;
}
}  // namespace

template <int D>
real Solver<D>::inlet_density(const InletSpec<D>& in, real z) const {
  // Hydrostatic below the opening's top (the inflow's free surface), inverted through Tait.
  const real rho0 = materials_[in.material].density;
  const real B = config_.speed_of_sound * config_.speed_of_sound * rho0 / config_.eos_gamma;
  const real g = std::abs(config_.gravity[D - 1]);
  const real p = rho0 * g * std::max(real(0), in.hi[D - 2] - z);
  return rho0 * std::pow(1 + p / B, 1 / config_.eos_gamma);
}

template <int D>
bool Solver<D>::in_inlet_buffer(const Vec<D>& p) const {
  const real length = inlet_buffer_layers(config_) * config_.dp;
  for (const auto& in : inlets_) {
    const real behind = in.direction * (in.at - p[in.axis]);  // distance upstream of the plane
    // Half a spacing of slack: a particle that just crossed may jitter back a little.
    if (behind < 0.5 * config_.dp || behind > length) continue;
    // Over the opening at any height: flow that piles up and spills back over the buffer leaves there too
    // (the inlet is the domain's upstream end).
    const auto ax = opening_axes<D>(in.axis);
    bool inside = p[D - 1] >= in.lo[D - 2] - 0.5 * config_.dp;
    for (int k = 0; k < D - 2; ++k) inside = inside && p[ax[k]] >= in.lo[k] && p[ax[k]] <= in.hi[k];
    if (inside) return true;
  }
  return false;
}

template <int D>
void Solver<D>::create_inlet_buffers() {
  const real dp = config_.dp;
  const int layers = inlet_buffer_layers(config_);
  for (size_t k = 0; k < inlets_.size(); ++k) {
    const auto& in = inlets_[k];
    const std::string what = "inlet '" + in.name + "'";
    if (in.axis < 0 || in.axis >= D - 1) throw std::invalid_argument(what + ": the axis must be horizontal");
    if (in.direction != 1 && in.direction != -1) throw std::invalid_argument(what + ": direction must be +1 or -1");
    if (in.material >= materials_.size()) throw std::invalid_argument(what + ": unknown material");
    if (in.speed.empty()) throw std::invalid_argument(what + ": needs a speed");
    for (const auto& s : in.speed)
      if (!(s[1] >= 0) || !std::isfinite(s[1])) throw std::invalid_argument(what + ": speeds must be >= 0");
    const auto ax = opening_axes<D>(in.axis);
    std::array<int, D - 1> count{};
    for (int j = 0; j < D - 1; ++j) {
      count[j] = static_cast<int>(std::floor((in.hi[j] - in.lo[j]) / dp + 1e-9));
      if (count[j] < 1)
        throw std::invalid_argument(what + ": the opening must be at least dp (" + std::to_string(dp) + " m) across");
    }
    const real back = in.at - in.direction * layers * dp;
    if (!config_.periodic[in.axis] && (std::min(back, in.at) < config_.domain_min[in.axis] ||
                                       std::max(back, in.at) > config_.domain_max[in.axis]))
      throw std::invalid_argument(what + ": its buffer (" + std::to_string(layers) + " layers of dp behind the plane) "
                                  "must lie inside the domain");
    const uint16_t mat = in.material;
    const real m = materials_[mat].density * std::pow(dp, D);
    const int total = D == 2 ? count[0] : count[0] * count[D - 2];
    for (int l = 0; l < layers; ++l)
      for (int c = 0; c < total; ++c) {
        Vec<D> p;
        p[in.axis] = in.at - in.direction * (l + 0.5) * dp;
        int rem = c;
        for (int j = 0; j < D - 1; ++j) {
          p[ax[j]] = in.lo[j] + (rem % count[j] + 0.5) * dp;
          rem /= count[j];
        }
        fluid_.add(p, inlet_density(in, p[D - 1]), m, mat, kInletBufferBit | static_cast<uint32_t>(k));
        fluid_.id.back() = next_id_++;
        fluid_.vel[in.axis].back() = in.direction * in.speed_at(0);
      }
  }
}

template <int D>
void Solver<D>::impose_inlet_state() {
  const size_t n = fluid_.size();
  const bool verlet = config_.integrator == Integrator::verlet;
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    if (!is_inlet_buffer(fluid_.tag[i])) continue;
    const auto& in = inlets_[fluid_.tag[i] & ~kInletBufferBit];
    const real u = in.direction * in.speed_at(time_);
    for (int d = 0; d < D; ++d) {
      fluid_.vel[d][i] = d == in.axis ? u : 0;
      if (verlet) vel_saved_[d][i] = fluid_.vel[d][i];
    }
    fluid_.rho[i] = inlet_density(in, fluid_.pos[D - 1][i]);
    if (verlet) rho_saved_[i] = fluid_.rho[i];
  }
}

template <int D>
void Solver<D>::advance_inlets() {
  const real length = inlet_buffer_layers(config_) * config_.dp;
  const size_t n = fluid_.size();
  for (size_t i = 0; i < n; ++i) {
    if (!is_inlet_buffer(fluid_.tag[i])) continue;
    const uint32_t k = fluid_.tag[i] & ~kInletBufferBit;
    const auto& in = inlets_[k];
    if (in.direction * (fluid_.pos[in.axis][i] - in.at) < 0) continue;
    // Across the plane: it is flow from now on, and its place at the back of the buffer is taken.
    fluid_.tag[i] = 0;
    const uint16_t mat = fluid_.material[i];
    mass_.inflow[mat] += fluid_.mass[i];
    real gx = 0, v2 = 0;
    for (int d = 0; d < D; ++d) gx += config_.gravity[d] * fluid_.pos[d][i], v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    potential_initial_ -= fluid_.mass[i] * gx;
    kinetic_inflow_ += 0.5 * fluid_.mass[i] * v2;
    Vec<D> p = fluid_.position(i);
    p[in.axis] -= in.direction * length;
    fluid_.add(p, fluid_.rho[i], fluid_.mass[i], mat, kInletBufferBit | k);
    fluid_.id.back() = next_id_++;
    for (int d = 0; d < D; ++d) fluid_.vel[d].back() = fluid_.vel[d][i];
  }
  // Per-particle state the integrators keep between steps must cover the new particles.
  const size_t m = fluid_.size();
  if (m > n) {
    for (int d = 0; d < D; ++d) {
      pos_saved_[d].resize(m);
      vel_saved_[d].resize(m);
      for (size_t i = n; i < m; ++i) pos_saved_[d][i] = fluid_.pos[d][i], vel_saved_[d][i] = fluid_.vel[d][i];
    }
    rho_saved_.resize(m);
    for (size_t i = n; i < m; ++i) rho_saved_[i] = fluid_.rho[i];
  }
}

template struct InletSpec<2>;
template struct InletSpec<3>;
template struct ParticleArrays<2>;
template struct ParticleArrays<3>;
template class Solver<2>;
template class Solver<3>;

}  // namespace runout
