#include "impl.hpp"
#include "runout/engine/eos.hpp"
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
const StepStats& Solver<D>::step() {
  const auto& cells = impl_->cells;
  if (wall_source_) refresh_wall_tiles(false);
  // The inlets' state first: the neighbour lists' reach depends on the speeds.
  if (!inlets_.empty()) impose_inlet_state();
  if (neighbour_lists_due()) sort_and_build_cells();
  evaluate(true);
  const real dt = record_.stats.dt;
  const size_t n = fluid_.size();
  const real rho0_b = config_.boundary_density;
  const bool shifting = config_.particle_shifting != ParticleShifting::none;
  const auto& acc = fluid_fields_.acc;
  const auto& drho = fluid_fields_.drho;
  const auto& wall_drho = wall_fields_.drho;
  // Density floor (config_.density_floor): the density at which the equation of state reaches the
  // material's tension floor (rho0 for a cohesionless material, whose pressure is floored at 0; none for a
  // liquid). Below it the pressure no longer changes, so nothing holds the continuity density: it drifts far
  // under rho0 while particles clump (0.3-0.5 dp apart), and the inflated volumes m/rho can make density
  // diffusion and the viscous term unstable (flume C6 at dp 0.04 m blew up at t = 3.48 s without it). The
  // walls' density has the same floor at their reference density, always.
  std::vector<real> rho_floor(materials_.size(), 0.0);
  if (config_.density_floor) {
    for (size_t k = 0; k < materials_.size(); ++k) {
      const TaitEOS eos(config_.speed_of_sound, materials_[k].density, config_.eos_gamma);
      const real p_min = -rheologies_[k]->tensile_strength();
      if (p_min > -eos.B) rho_floor[k] = (1.0 - config_.max_dilatancy) * eos.density(p_min);
    }
  }
  const real* rho_floor_of = rho_floor.data();

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
    for (int d = 0; d < D; ++d) vn += fluid_.vel[d][i] * fluid_fields_.contact_normal[d][i];
    if (vn >= 0) return;
    real vt2 = 0;
    for (int d = 0; d < D; ++d) {
      fluid_.vel[d][i] -= vn * fluid_fields_.contact_normal[d][i];
      vt2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    }
    const real mu = contact_friction_of[fluid_.material[i]];
    if (mu > 0 && vt2 > 0) {
      const real keep = std::max(real(0), 1 + mu * vn / std::sqrt(vt2));
      for (int d = 0; d < D; ++d) fluid_.vel[d][i] *= keep;
    }
  };

  if (config_.integrator == Integrator::symplectic) {
    // Predictor (thesis eq. 2.25). With the implicit viscous step the half-step velocities go through it too
    // (at the step's start positions, where the pair lists are), so the midpoint's shear rate, and the mu_eff
    // the regularised yield stress gives, see the viscous stress: without it a resting plug carrying its weight
    // in shear showed a spurious hdt a shear rate at the midpoint and crept (docs/design.md).
    const real hdt = 0.5 * dt;
    const bool implicit = implicit_viscosity();
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      for (int d = 0; d < D; ++d) {
        saved_.pos[d][i] = fluid_.pos[d][i];
        saved_.vel[d][i] = fluid_.vel[d][i];
        fluid_.vel[d][i] += hdt * acc[d][i];
      }
      saved_.rho[i] = fluid_.rho[i];
      fluid_.rho[i] = std::max(rho_floor_of[fluid_.material[i]], fluid_.rho[i] + hdt * drho[i]);
    }
    if (implicit) implicit_viscous_step(hdt);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i)
      for (int d = 0; d < D; ++d) fluid_.pos[d][i] += hdt * saved_.vel[d][i];
    cells.for_each_active_wall([&](uint32_t b) {
      saved_.boundary_rho[b] = boundary_.rho[b];
      boundary_.rho[b] = std::max(rho0_b, boundary_.rho[b] + hdt * wall_drho[b]);
    });
    evaluate(false);
    // Corrector (thesis eq. 2.26); with the implicit viscous step the velocities then go through it, before
    // the wall contact and the positions see them.
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i)
      for (int d = 0; d < D; ++d) fluid_.vel[d][i] = saved_.vel[d][i] + dt * acc[d][i];
    if (implicit) implicit_viscous_step(dt);
    // The shift's concentration gradient at the midpoint, where the pair lists are (as DualSPHysics: corrector only).
    if (shifting) shifting_gradients();
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      stop_wall_approach(i);
      for (int d = 0; d < D; ++d)
        fluid_.pos[d][i] = saved_.pos[d][i] + dt * 0.5 * (fluid_.vel[d][i] + saved_.vel[d][i]);
      const real eps = -drho[i] / fluid_.rho[i] * dt;
      fluid_.rho[i] = std::max(rho_floor_of[fluid_.material[i]], saved_.rho[i] * (2.0 - eps) / (2.0 + eps));
    }
    if (shifting) apply_shifting(dt);
    cells.for_each_active_wall([&](uint32_t b) {
      const real eps = -wall_drho[b] / boundary_.rho[b] * dt;
      boundary_.rho[b] = std::max(rho0_b, saved_.boundary_rho[b] * (2.0 - eps) / (2.0 + eps));
    });
  } else {
    // Verlet (thesis eq. 2.23-2.24): the saved arrays hold the values at n-1.
    const bool euler = config_.verlet_reset_steps > 0 && (record_.steps + 1) % config_.verlet_reset_steps == 0;
    if (shifting) shifting_gradients();
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      for (int d = 0; d < D; ++d) {
        const real v = fluid_.vel[d][i];
        const real v_new = euler ? v + dt * acc[d][i] : saved_.vel[d][i] + 2.0 * dt * acc[d][i];
        fluid_.pos[d][i] += dt * v + 0.5 * dt * dt * acc[d][i];
        saved_.vel[d][i] = v;
        fluid_.vel[d][i] = v_new;
      }
      stop_wall_approach(i);
      const real r = fluid_.rho[i];
      fluid_.rho[i] =
          std::max(rho_floor_of[fluid_.material[i]], euler ? r + dt * drho[i] : saved_.rho[i] + 2.0 * dt * drho[i]);
      saved_.rho[i] = r;
    }
    cells.for_each_active_wall([&](uint32_t b) {
      const real r = boundary_.rho[b];
      const real next = euler ? r + dt * wall_drho[b] : saved_.boundary_rho[b] + 2.0 * dt * wall_drho[b];
      boundary_.rho[b] = std::max(rho0_b, next);
      saved_.boundary_rho[b] = r;
    });
    if (shifting) apply_shifting(dt);
  }

  record_.time += dt;
  ++record_.steps;
  record_.min_dt_seen = std::min(record_.min_dt_seen, dt);
  if (!inlets_.empty()) advance_inlets();
  check_state();
  return record_.stats;
}

template const StepStats& Solver<2>::step();
template const StepStats& Solver<3>::step();

}  // namespace runout
