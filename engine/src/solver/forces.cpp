// One force evaluation: the fluid's state from the EOS, the pair lists, the wall model's pressure, the pair
// passes (passes.hpp), the rheology between them, and the time step from the evaluation's maxima.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "../wall/registry.hpp"
#include "impl.hpp"
#include "passes.hpp"

namespace runout {

// Per material: the EOS and its tension floor; per fluid particle: p, 1/rho, m/rho, p/rho^2 and the
// neighbour pack.
template <int D>
void Solver<D>::update_fluid_state() {
  auto& pass = impl_->pass;
  const size_t n = fluid_.size(), nm = materials_.size();
  pass.eos.resize(nm);
  pass.rho0.resize(nm);
  pass.p_min.resize(nm);
  pass.wall_friction.resize(nm);
  for (size_t k = 0; k < nm; ++k) {
    pass.rho0[k] = materials_[k].density;
    pass.eos[k] = TaitEOS(config_.speed_of_sound, pass.rho0[k], config_.eos_gamma);
    // A cohesionless granular material carries no tension: without this floor a spreading sheet goes into
    // tension, clumps and sinks into the bed's lattice (docs/validation.md, "Thin sheets on terrain").
    pass.p_min[k] = -rheologies_[k]->tensile_strength();
    pass.wall_friction[k] = rheologies_[k]->wall_friction_coefficient();
  }
  pass.vol.resize(n);
  pass.pt.resize(n);
  pass.inv_rho.resize(n);
  using PK = Pack<D>;
  pass.neighbour_pack.resize(PK::kStride * n);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const int k = fluid_.material[i];
    const real r = fluid_.rho[i];
    fluid_fields_.pressure[i] = std::max(pass.eos[k].pressure(r), pass.p_min[k]);
    pass.inv_rho[i] = 1.0 / r;
    pass.vol[i] = fluid_.mass[i] * pass.inv_rho[i];
    pass.pt[i] = fluid_fields_.pressure[i] * pass.inv_rho[i] * pass.inv_rho[i];
    real* pk = pass.neighbour_pack.data() + PK::kStride * i;
    for (int d = 0; d < D; ++d) pk[d] = fluid_.vel[d][i];
    pk[PK::kRho] = r;
    pk[PK::kVol] = pass.vol[i];
    pk[PK::kPt] = pass.pt[i];
    pk[PK::kPm] = fluid_fields_.pressure[i];
    pk[PK::kInvRho] = pass.inv_rho[i];
  }
}

// The passes' pointers and constants (valid until the particle arrays next change size), with the
// per-thread accumulators and wall volumes sized and the maxima reset.
template <int D>
PassContext<D> Solver<D>::pass_context() {
  auto& cells = impl_->cells;
  auto& pass = impl_->pass;
  const int nthreads = omp_get_max_threads();
  pass.acc_f.resize(nthreads);
  pass.acc_b.resize(nthreads);
  pass.bvol.resize(boundary_.size());
  pass.bpt.resize(boundary_.size());
  pass.maxima = PassMaxima{};
  const real h = config_.smoothing_length, c0 = config_.speed_of_sound;
  PassContext<D> c;
  c.h = h;
  c.c0 = c0;
  c.eta2 = 0.01 * h * h;
  c.alpha = config_.artificial_viscosity;
  c.inv_c0_sq = 1.0 / (c0 * c0);
  c.contact2 = kWallContact * kWallContact * config_.dp * config_.dp;
  // Slip speed below which basal Coulomb friction is proportional to the slip (regularisation).
  c.v_slip = 0.01 * std::sqrt(9.81 * config_.dp);
  const bool ddt_on = config_.density_diffusion != DensityDiffusion::none && config_.density_diffusion_delta > 0;
  c.ddt_coef = ddt_on ? 2.0 * config_.density_diffusion_delta * h * c0 : 0.0;
  c.fourtakas = config_.density_diffusion == DensityDiffusion::fourtakas;
  c.period = cells.period;
  c.any_periodic = false;
  c.explicit_viscosity = !implicit_viscosity();
  // The implicit step's friction needs no regularisation against chatter (its drag is solved backward in time),
  // only one that keeps the lagged secant coefficient finite: 1 % of the explicit slip speed, so a layer held by
  // friction creeps at most about that (docs/design.md, "Implicit viscous step").
  if (!c.explicit_viscosity) c.v_slip *= 0.01;
  c.friction_drag = pass.friction_drag.data();
  for (int d = 0; d < D; ++d) {
    c.g[d] = config_.gravity[d];
    c.any_periodic = c.any_periodic || cells.period[d] > 0;
    c.P[d] = fluid_.pos[d].data();
    c.V[d] = fluid_.vel[d].data();
    c.BP[d] = boundary_.pos[d].data();
    c.BN[d] = wall_fields_.normal[d].data();
    c.acc[d] = fluid_fields_.acc[d].data();
    c.contact_normal[d] = fluid_fields_.contact_normal[d].data();
    c.friction_normal[d] = pass.friction_normal[d].data();
  }
  c.rho0 = pass.rho0.data();
  c.wall_friction = pass.wall_friction.data();
  c.mass = fluid_.mass.data();
  c.rho = fluid_.rho.data();
  c.press = fluid_fields_.pressure.data();
  c.vol = pass.vol.data();
  c.pt = pass.pt.data();
  c.inv_rho = pass.inv_rho.data();
  c.pack = pass.neighbour_pack.data();
  c.mat = fluid_.material.data();
  c.bmass = boundary_.mass.data();
  c.brho = boundary_.rho.data();
  c.bvol = pass.bvol.data();
  c.bpt = pass.bpt.data();
  c.bslot = cells.bslot.data();
  c.mu_eff = fluid_fields_.mu_eff.data();
  c.mu_wall = fluid_fields_.mu_wall.data();
  c.drho = fluid_fields_.drho.data();
  c.boundary_drho = wall_fields_.drho.data();
  c.yield_pressure = fluid_fields_.yield_pressure.data();
  c.shear_rate = fluid_fields_.shear_rate.data();
  return c;
}

template <int D>
void Solver<D>::evaluate(bool compute_dt) {
  auto& I = *impl_;
  auto& cells = I.cells;
  const size_t n = fluid_.size();
  const real h = config_.smoothing_length, c0 = config_.speed_of_sound;
  bool viscous = false;
  for (const auto& r : rheologies_) viscous = viscous || !r->is_inviscid();
  update_fluid_state();
  with_kernel<D>(config_.kernel, h, [&](auto kernel) { update_pair_lists(kernel.support()); });
  if (implicit_viscosity()) {  // the friction drag the wall pairs leave for the implicit step
    I.pass.friction_drag.assign(n, 0.0);
    for (int d = 0; d < D; ++d) I.pass.friction_normal[d].resize(n);
  }

  const PassContext<D> c = pass_context();
  const TaitEOS eos_b(c0, config_.boundary_density, config_.eos_gamma);
  with_kernel<D>(config_.kernel, h, [&](auto kernel) {
    wall::with_wall_model(config_.boundary_pressure, [&](auto wall_model) {
      using Wall = decltype(wall_model);
      Wall::update_pressure(c, kernel, I, n, eos_b, wall_fields_.pressure.data(), boundary_.rho.data());
      update_wall_volumes();
      using Pairs = typename Wall::template Pairs<D>;
      if (viscous) {
        velocity_gradient_pass<Pairs>(c, kernel, I, n, config_.shear_rate_floor);
        apply_rheology();
        momentum_pass<true, Pairs>(c, kernel, I, n);
      } else {
        momentum_pass<false, Pairs>(c, kernel, I, n);
      }
    });
  });
  // Inlet buffers move at their inlet's velocity with a fixed density: no rates, no wall contact.
  if (!inlets_.empty()) {
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      if (!is_inlet_buffer(fluid_.tag[i])) continue;
      for (int d = 0; d < D; ++d) fluid_fields_.acc[d][i] = 0, fluid_fields_.contact_normal[d][i] = 0;
      fluid_fields_.drho[i] = 0;
    }
  }
  record_.stats.active_boundary = cells.active_boundary_count;
  if (compute_dt) set_time_step(viscous);
}

template <int D>
void Solver<D>::update_wall_volumes() {
  auto& pass = impl_->pass;
  impl_->cells.for_each_active_wall([&](uint32_t b) {
    const real rb = boundary_.rho[b];
    pass.bvol[b] = boundary_.mass[b] / rb;
    pass.bpt[b] = wall_fields_.pressure[b] / (rb * rb);
  });
}

// Monaghan & Kos (1999), thesis eq. 2.27, plus the viscous limit with the capped mu_eff.
template <int D>
void Solver<D>::set_time_step(bool viscous) {
  const PassMaxima& m = impl_->pass.maxima;
  StepStats& stats = record_.stats;
  const real h = config_.smoothing_length;
  const real max_acc = std::sqrt(m.acc2);
  stats.dt_force = max_acc > 0 ? std::sqrt(h / max_acc) : 1e300;
  stats.dt_acoustic = h / (config_.speed_of_sound + m.visc_term);
  stats.dt_viscous = m.nu > 0 ? 0.125 * h * h / m.nu : 1e300;
  // The implicit viscous step is unconditionally stable: its limit is reported, not applied.
  const real dt_viscous_applied = implicit_viscosity() ? 1e300 : stats.dt_viscous;
  stats.dt = std::min(config_.cfl * std::min(stats.dt_force, stats.dt_acoustic), dt_viscous_applied);
  stats.max_effective_viscosity = 0;
  if (viscous)
    for (size_t i = 0; i < fluid_.size(); ++i)
      stats.max_effective_viscosity = std::max(stats.max_effective_viscosity, fluid_fields_.mu_eff[i]);
  if (!(stats.dt >= config_.min_dt)) {
    std::ostringstream s;
    s << fmt_time(record_.time) << ": time step " << stats.dt << " s fell below the floor " << config_.min_dt
      << " s (force limit " << stats.dt_force << " s, acoustic " << stats.dt_acoustic << " s, viscous "
      << stats.dt_viscous << " s)";
    throw SimulationError(s.str(), SimulationError::Cause::dt_floor);
  }
}

template <int D>
void Solver<D>::evaluate_rates() {
  sort_and_build_cells();
  evaluate(false);
}

#define RUNOUT_INSTANTIATE_EVALUATION(D)             \
  template void Solver<D>::update_fluid_state();      \
  template void Solver<D>::update_wall_volumes();     \
  template void Solver<D>::set_time_step(bool);       \
  template PassContext<D> Solver<D>::pass_context();  \
  template void Solver<D>::evaluate(bool);            \
  template void Solver<D>::evaluate_rates();
RUNOUT_INSTANTIATE_EVALUATION(2)
RUNOUT_INSTANTIATE_EVALUATION(3)
#undef RUNOUT_INSTANTIATE_EVALUATION

}  // namespace runout
