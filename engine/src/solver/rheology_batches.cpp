// The rheology step between the two passes: each material's mu_eff from the shear rate and the
// kernel-averaged pressure of pass 1, one call per material batch, then capped.
#include "impl.hpp"

namespace runout {

template <int D>
void Solver<D>::apply_rheology() {
  auto& I = *impl_;
  const size_t n = fluid_.size();
  const std::vector<real>& wall_friction = I.pass.wall_friction;
  if (materials_.size() == 1) {
    rheologies_[0]->effective_viscosity(fluid_fields_.shear_rate, fluid_fields_.yield_pressure, fluid_fields_.mu_eff);
    // Friction rheologies: the wall side of a fluid-wall pair sees the viscosity at zero pressure (the
    // basal friction carries the pressure-dependent part).
    if (wall_friction[0] > 0) {
      std::fill(fluid_fields_.zero_pressure.begin(), fluid_fields_.zero_pressure.end(), real(0));
      rheologies_[0]->effective_viscosity(fluid_fields_.shear_rate, fluid_fields_.zero_pressure, fluid_fields_.mu_wall);
    }
  } else {
    for (size_t k = 0; k < materials_.size(); ++k) {
      std::vector<uint32_t> idx;
      for (size_t i = 0; i < n; ++i)
        if (fluid_.material[i] == k) idx.push_back(static_cast<uint32_t>(i));
      std::vector<real> gd(idx.size()), p(idx.size()), mu(idx.size());
      for (size_t q = 0; q < idx.size(); ++q) {
        gd[q] = fluid_fields_.shear_rate[idx[q]];
        p[q] = fluid_fields_.yield_pressure[idx[q]];
      }
      rheologies_[k]->effective_viscosity(gd, p, mu);
      for (size_t q = 0; q < idx.size(); ++q) fluid_fields_.mu_eff[idx[q]] = mu[q];
      if (wall_friction[k] > 0) {
        std::fill(p.begin(), p.end(), real(0));
        rheologies_[k]->effective_viscosity(gd, p, mu);
        for (size_t q = 0; q < idx.size(); ++q) fluid_fields_.mu_wall[idx[q]] = mu[q];
      }
    }
  }
  const real cap = max_viscosity_;
  real max_nu = 0;
#pragma omp parallel for schedule(static) reduction(max : max_nu)
  for (size_t i = 0; i < n; ++i) {
    const real mu = std::min(fluid_fields_.mu_eff[i], cap);
    fluid_fields_.mu_eff[i] = mu;
    fluid_fields_.mu_wall[i] = wall_friction[fluid_.material[i]] > 0 ? std::min(fluid_fields_.mu_wall[i], cap) : mu;
    max_nu = std::max(max_nu, mu / fluid_.rho[i]);
    I.pass.neighbour_pack[Pack<D>::kStride * i + Pack<D>::kPm] = mu;  // pass 2 reads mu_eff where pass 1 read p
  }
  I.pass.maxima.nu = std::max(I.pass.maxima.nu, max_nu);
}

template void Solver<2>::apply_rheology();
template void Solver<3>::apply_rheology();

}  // namespace runout
