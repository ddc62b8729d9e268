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
  auto& I = *impl_;
  const size_t n = fluid_.size(), nm = materials_.size();
  I.eos.resize(nm);
  I.rho0.resize(nm);
  I.p_min.resize(nm);
  I.wall_friction.resize(nm);
  for (size_t k = 0; k < nm; ++k) {
    I.rho0[k] = materials_[k].density;
    I.eos[k] = TaitEOS(config_.speed_of_sound, I.rho0[k], config_.eos_gamma);
    // A cohesionless granular material carries no tension: without this floor a spreading sheet goes into
    // tension, clumps and sinks into the bed's lattice (docs/validation.md, "Thin sheets on terrain").
    I.p_min[k] = -rheologies_[k]->tensile_strength();
    I.wall_friction[k] = rheologies_[k]->wall_friction_coefficient();
  }
  I.vol.resize(n);
  I.pt.resize(n);
  I.inv_rho.resize(n);
  using PK = Pack<D>;
  I.neighbour_pack.resize(PK::kStride * n);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const int k = fluid_.material[i];
    const real r = fluid_.rho[i];
    pressure_[i] = std::max(I.eos[k].pressure(r), I.p_min[k]);
    I.inv_rho[i] = 1.0 / r;
    I.vol[i] = fluid_.mass[i] * I.inv_rho[i];
    I.pt[i] = pressure_[i] * I.inv_rho[i] * I.inv_rho[i];
    real* pk = I.neighbour_pack.data() + PK::kStride * i;
    for (int d = 0; d < D; ++d) pk[d] = fluid_.vel[d][i];
    pk[PK::kRho] = r;
    pk[PK::kVol] = I.vol[i];
    pk[PK::kPt] = I.pt[i];
    pk[PK::kPm] = pressure_[i];
    pk[PK::kInvRho] = I.inv_rho[i];
  }
}

// The passes' pointers and constants (valid until the particle arrays next change size), with the
// per-thread accumulators and wall volumes sized and the maxima reset.
template <int D>
PassContext<D> Solver<D>::pass_context() {
  auto& I = *impl_;
  const int nthreads = omp_get_max_threads();
  I.acc_f.resize(nthreads);
  I.acc_b.resize(nthreads);
  I.bvol.resize(boundary_.size());
  I.bpt.resize(boundary_.size());
  I.maxima = PassMaxima{};
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
  c.period = I.period;
  c.any_periodic = false;
  c.explicit_viscosity = !implicit_viscosity();
  // The implicit step's friction needs no regularisation against chatter (its drag is solved backward in time),
  // only one that keeps the lagged secant coefficient finite: 1 % of the explicit slip speed, so a layer held by
  // friction creeps at most about that (docs/design.md, "Implicit viscous step").
  if (!c.explicit_viscosity) c.v_slip *= 0.01;
  c.friction_drag = I.friction_drag.data();
  for (int d = 0; d < D; ++d) {
    c.g[d] = config_.gravity[d];
    c.any_periodic = c.any_periodic || I.period[d] > 0;
    c.P[d] = fluid_.pos[d].data();
    c.V[d] = fluid_.vel[d].data();
    c.BP[d] = boundary_.pos[d].data();
    c.BN[d] = boundary_normal_[d].data();
    c.acc[d] = acc_[d].data();
    c.contact_normal[d] = contact_normal_[d].data();
    c.friction_normal[d] = I.friction_normal[d].data();
  }
  c.rho0 = I.rho0.data();
  c.wall_friction = I.wall_friction.data();
  c.mass = fluid_.mass.data();
  c.rho = fluid_.rho.data();
  c.press = pressure_.data();
  c.vol = I.vol.data();
  c.pt = I.pt.data();
  c.inv_rho = I.inv_rho.data();
  c.pack = I.neighbour_pack.data();
  c.mat = fluid_.material.data();
  c.bmass = boundary_.mass.data();
  c.brho = boundary_.rho.data();
  c.bvol = I.bvol.data();
  c.bpt = I.bpt.data();
  c.bslot = I.bslot.data();
  c.mu_eff = mu_eff_.data();
  c.mu_wall = mu_wall_.data();
  c.drho = drho_.data();
  c.boundary_drho = boundary_drho_.data();
  c.yield_pressure = yield_pressure_.data();
  c.shear_rate = shear_rate_.data();
  return c;
}

template <int D>
void Solver<D>::evaluate(bool compute_dt) {
  auto& I = *impl_;
  const size_t n = fluid_.size();
  const real h = config_.smoothing_length, c0 = config_.speed_of_sound;
  bool viscous = false;
  for (const auto& r : rheologies_) viscous = viscous || !r->is_inviscid();
  update_fluid_state();
  with_kernel<D>(config_.kernel, h, [&](auto kernel) { update_pair_lists(kernel.support()); });
  if (implicit_viscosity()) {  // the friction drag the wall pairs leave for the implicit step
    I.friction_drag.assign(n, 0.0);
    for (int d = 0; d < D; ++d) I.friction_normal[d].resize(n);
  }

  const PassContext<D> c = pass_context();
  const TaitEOS eos_b(c0, config_.boundary_density, config_.eos_gamma);
  with_kernel<D>(config_.kernel, h, [&](auto kernel) {
    wall::with_wall_model(config_.boundary_pressure, [&](auto wall_model) {
      using Wall = decltype(wall_model);
      Wall::update_pressure(c, kernel, I, n, eos_b, boundary_pressure_.data(), boundary_.rho.data());
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
      for (int d = 0; d < D; ++d) acc_[d][i] = 0, contact_normal_[d][i] = 0;
      drho_[i] = 0;
    }
  }
  stats_.active_boundary = 0;
  for (uint32_t cb : I.active_bcells) stats_.active_boundary += I.bcell_begin[cb + 1] - I.bcell_begin[cb];
  if (compute_dt) set_time_step(viscous);
}

template <int D>
void Solver<D>::update_wall_volumes() {
  auto& I = *impl_;
  const size_t nact = I.active_bcells.size();
#pragma omp parallel for schedule(static)
  for (size_t a = 0; a < nact; ++a) {
    const uint32_t cb = I.active_bcells[a];
    for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) {
      const real rb = boundary_.rho[b];
      I.bvol[b] = boundary_.mass[b] / rb;
      I.bpt[b] = boundary_pressure_[b] / (rb * rb);
    }
  }
}

// Monaghan & Kos (1999), thesis eq. 2.27, plus the viscous limit with the capped mu_eff.
template <int D>
void Solver<D>::set_time_step(bool viscous) {
  const PassMaxima& m = impl_->maxima;
  const real h = config_.smoothing_length;
  const real max_acc = std::sqrt(m.acc2);
  stats_.dt_force = max_acc > 0 ? std::sqrt(h / max_acc) : 1e300;
  stats_.dt_acoustic = h / (config_.speed_of_sound + m.visc_term);
  stats_.dt_viscous = m.nu > 0 ? 0.125 * h * h / m.nu : 1e300;
  // The implicit viscous step is unconditionally stable: its limit is reported, not applied.
  const real dt_viscous_applied = implicit_viscosity() ? 1e300 : stats_.dt_viscous;
  stats_.dt = std::min(config_.cfl * std::min(stats_.dt_force, stats_.dt_acoustic), dt_viscous_applied);
  stats_.max_effective_viscosity = 0;
  if (viscous)
    for (size_t i = 0; i < fluid_.size(); ++i)
      stats_.max_effective_viscosity = std::max(stats_.max_effective_viscosity, mu_eff_[i]);
  if (!(stats_.dt >= config_.min_dt)) {
    std::ostringstream s;
    s << fmt_time(time_) << ": time step " << stats_.dt << " s fell below the floor " << config_.min_dt
      << " s (force limit " << stats_.dt_force << " s, acoustic " << stats_.dt_acoustic << " s, viscous "
      << stats_.dt_viscous << " s)";
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
