#include "impl.hpp"
#include "runout/engine/eos.hpp"
#include "wall_normals.hpp"
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

// The fixed wall particles' normals: as the scene gives them; those it does not give (none, or zero vectors)
// are estimated from the arrangement of those particles alone within the kernel support, so a wall whose
// normals are given (a bed laid whole) does not change the others' from what they are when it is laid in
// tiles (the wall source's tiles bring their own).
template <int D>
void Solver<D>::set_fixed_wall_normals(const std::vector<Vec<D>>& given) {
  const size_t nb = boundary_.size();
  if (!given.empty() && given.size() != nb)
    throw std::invalid_argument("boundary_normals: one per boundary particle or none");
  std::vector<size_t> unknown;
  for (size_t b = 0; b < nb; ++b)
    if (given.empty() || given[b].isZero()) unknown.push_back(b);
  std::array<std::vector<real>, D> pos;
  for (int d = 0; d < D; ++d)
    for (size_t b : unknown) pos[d].push_back(boundary_.pos[d][b]);
  Vec<D> period;
  for (int d = 0; d < D; ++d) period[d] = config_.periodic[d] ? config_.domain_max[d] - config_.domain_min[d] : 0.0;
  const std::vector<Vec<D>> estimated =
      solver_detail::estimate_wall_normals<D>(pos, 2.0 * config_.smoothing_length, period);
  std::vector<Vec<D>> normals = given.empty() ? std::vector<Vec<D>>(nb, Vec<D>::Zero()) : given;
  for (size_t k = 0; k < unknown.size(); ++k) normals[unknown[k]] = estimated[k];
  for (int d = 0; d < D; ++d) {
    wall_fields_.normal[d].resize(nb);
    for (size_t b = 0; b < nb; ++b) {
      const real len = normals[b].norm();
      wall_fields_.normal[d][b] = len > 0 ? normals[b][d] / len : 0.0;
    }
  }
}

long double MassBalance::total_initial() const { return std::accumulate(initial.begin(), initial.end(), 0.0L); }
long double MassBalance::total_current() const { return std::accumulate(current.begin(), current.end(), 0.0L); }
long double MassBalance::total_outflow() const { return std::accumulate(outflow.begin(), outflow.end(), 0.0L); }
long double MassBalance::total_inflow() const { return std::accumulate(inflow.begin(), inflow.end(), 0.0L); }

// Grid: cells of half the reach (the support and the neighbour skin), searched two cells each way; a periodic
// axis gets a whole number (>= 5) of cells, so a short one takes a smaller skin (none at 5h).
template <int D>
void Solver<D>::set_up_cells() {
  auto& cells = impl_->cells;
  const real h = config_.smoothing_length, support = 2.0 * h;
  for (int d = 0; d < D; ++d) {
    const real most = (2.0 * (config_.domain_max[d] - config_.domain_min[d]) / 5 * (1 - 1e-9) - support) / h;
    if (config_.periodic[d]) config_.neighbour_skin = std::max<real>(0, std::min(config_.neighbour_skin, most));
  }
  const real reach = support + neighbour_skin();
  for (int d = 0; d < D; ++d) {
    cells.cell_size[d] = 0.5 * reach;
    cells.origin[d] = 0.0;
    cells.period[d] = 0.0;
    if (config_.periodic[d]) {
      if (d == D - 1) throw std::invalid_argument("domain.periodic: the vertical axis cannot be periodic");
      const real L = config_.domain_max[d] - config_.domain_min[d];
      const int64_t n = static_cast<int64_t>(std::floor(L / (0.5 * reach)));
      if (n < 2 * CellIndex<D>::kReach + 1)
        throw std::invalid_argument("domain.periodic: a periodic axis must be at least 5h long");
      cells.periodic_cells[d] = n;
      cells.cell_size[d] = L / static_cast<real>(n);
      cells.origin[d] = config_.domain_min[d];
      cells.period[d] = L;
    }
    cells.inv_cell[d] = 1.0 / cells.cell_size[d];
  }
  // Non-periodic origin: the lower corner of all particles, so keys stay small.
  for (int d = 0; d < D; ++d) {
    if (config_.periodic[d]) continue;
    real lo = 1e300;
    for (real x : fluid_.pos[d]) lo = std::min(lo, x);
    for (real x : boundary_.pos[d]) lo = std::min(lo, x);
    if (wall_source_ && wall_source_->total() > 0) lo = std::min(lo, wall_source_->lowest()[d]);
    cells.origin[d] = (lo < 1e299 ? lo : 0.0) - support;
  }
  {
    int nshift = 1;
    for (int d = 0; d < D - 1; ++d) nshift *= 3;
    cells.shifts.resize(nshift);
    for (int o = 0; o < nshift; ++o) {
      int rem = o;
      Vec<D> sv = Vec<D>::Zero();
      for (int d = 0; d < D - 1; ++d) {
        sv[d] = (rem % 3 - 1) * cells.period[d];
        rem /= 3;
      }
      cells.shifts[o] = sv;
    }
  }
}

template <int D>
Solver<D>::Solver(SceneSetup<D> setup)
    : impl_(std::make_unique<Impl>()),
      config_(setup.config),
      materials_(std::move(setup.materials)),
      leak_regions_(std::move(setup.leak_regions)),
      inlets_(std::move(setup.inlets)),
      wall_source_(std::move(setup.wall_source)),
      max_particles_(setup.max_particles),
      fluid_(std::move(setup.fluid)),
      boundary_(std::move(setup.boundary)) {
  auto& tiles = impl_->tiles;
  for (const auto& m : materials_) rheologies_.push_back(make_rheology(m));
  for (uint32_t id : fluid_.id) next_id_ = std::max(next_id_, id + 1);
  create_inlet_buffers();
  if (!(config_.neighbour_skin >= 0 && config_.neighbour_skin <= 1))
    throw std::invalid_argument("numerics.neighbour_skin: must be between 0 and 1 (a fraction of h)");
  for (int d = 0; d < D && wall_source_; ++d)
    if (config_.periodic[d]) throw std::invalid_argument("domain.periodic: a scene with a wall source cannot be periodic");

  const real h = config_.smoothing_length;
  if (config_.viscous_step == ViscousStep::implicit && config_.integrator != Integrator::symplectic)
    throw std::invalid_argument("numerics.viscosity: implicit needs the symplectic integrator (accepted: symplectic)");
  // Auto viscosity cap: the mu_eff at which the viscous limit 0.125 h^2 rho / mu equals cfl h / c0. The implicit
  // step needs none: only a cap the scene gives in Pa s applies there.
  if (config_.max_viscosity > 0) {
    max_viscosity_ = config_.max_viscosity;
  } else if (config_.viscous_step == ViscousStep::implicit) {
    max_viscosity_ = std::numeric_limits<real>::infinity();
  } else {
    real rho_min = 1e300;
    for (const auto& m : materials_) rho_min = std::min(rho_min, m.density);
    max_viscosity_ = config_.viscosity_cap_factor * 0.125 * h * rho_min * config_.speed_of_sound / config_.cfl;
  }

  set_up_cells();

  // Boundary particles never move: the fixed ones are sorted by cell once, with the wall source's tiles near
  // the flow when there is one (wall_tiles.cpp).
  tiles.fixed = boundary_.size();
  tiles.of_wall.assign(boundary_.size(), -1);
  tiles.rank.resize(boundary_.size());
  std::iota(tiles.rank.begin(), tiles.rank.end(), uint64_t{0});
  saved_.boundary_rho = boundary_.rho;
  wall_fields_.pressure.assign(boundary_.size(), 0.0);
  wall_fields_.drho.assign(boundary_.size(), 0.0);
  set_fixed_wall_normals(setup.boundary_normals);
  if (wall_source_) {
    tiles.grid = wall_source_->tiles();
    tiles.live.assign(static_cast<size_t>(tiles.grid.count()), 0);
    tiles.mark.assign(static_cast<size_t>(tiles.grid.count()), 0u);
    refresh_wall_tiles(true);
  } else {
    sort_boundary();
    boundary_peak_ = boundary_.size();
  }

  balance_.mass.initial.assign(materials_.size(), 0.0L);
  balance_.mass.outflow.assign(materials_.size(), 0.0L);
  balance_.mass.inflow.assign(materials_.size(), 0.0L);
  for (size_t i = 0; i < fluid_.size(); ++i)
    if (!is_inlet_buffer(fluid_.tag[i])) balance_.mass.initial[fluid_.material[i]] += fluid_.mass[i];
  balance_.potential_initial = potential_energy();
  // Verlet keeps the previous step's velocity and density in the saved arrays.
  for (int d = 0; d < D; ++d) {
    saved_.pos[d] = fluid_.pos[d];
    saved_.vel[d] = fluid_.vel[d];
  }
  saved_.rho = fluid_.rho;
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
  MassBalance m = balance_.mass;
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
  e.potential_released = balance_.potential_initial - (potential_energy() + balance_.potential_outflow);
  e.inflow_kinetic = balance_.kinetic_inflow;
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

template struct ParticleArrays<2>;
template struct ParticleArrays<3>;
template class Solver<2>;
template class Solver<3>;

}  // namespace runout
