// mu(I) dense granular rheology (Jop, Forterre & Pouliquen 2006, Nature 441): the shear stress is mu(I) P with
//   mu(I) = mu_s + (mu_2 - mu_s) / (I0 / I + 1),   I = |gamma_dot| d / sqrt(P / rho_s),
// so mu_eff = mu(I) max(P, 0) / |gamma_dot|. rho_s = rho0 / solid_fraction is the grains' density. At small I the
// friction tends to mu_s and mu_eff diverges like 1/|gamma_dot|; it is regularised as the HBP family's yield
// part, by (1 - exp(-m |gamma_dot|)) (exact for m |gamma_dot| >> 1), and the solver's cap bounds it.
// The wall shears a particle with its own mu_eff (wall_friction_coefficient 0): a rough, no-slip base, as in
// the inclined-plane experiments the law was fitted to.
#include "laws.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::rheology {
namespace {

class MuI final : public Rheology {
 public:
  MuI(real mu_s, real mu_2, real i0, real grain_diameter, real grain_density, real regularisation)
      : mu_s_(mu_s), dmu_(mu_2 - mu_s), i0_(i0), d_(grain_diameter), rho_s_(grain_density), m_(regularisation) {}
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real> pressure,
                           std::span<real> mu_eff) const override {
    for (size_t k = 0; k < mu_eff.size(); ++k) {
      const real g = gamma_dot[k];
      const real p = pressure[k] > 0 ? pressure[k] : 0.0;
      // I / I0 = g d / (I0 sqrt(p / rho_s)); mu(I) = mu_s + dmu I / (I0 + I). p = 0: I infinite, stress 0.
      const real root = std::sqrt(p / rho_s_);
      const real i = g * d_;
      const real mu = mu_s_ + dmu_ * i / (i0_ * root + i);
      mu_eff[k] = p > 0 ? mu * p * papanastasiou_factor(m_, g) : 0.0;
    }
  }
  // Cohesionless: no tension (the solver floors the pressure at 0).
  real tensile_strength() const override { return 0.0; }
  real yield_stress(real pressure) const override { return mu_s_ * (pressure > 0 ? pressure : 0.0); }

 private:
  real mu_s_, dmu_, i0_, d_, rho_s_, m_;
};

}  // namespace

extern const RheologyModel mu_i_model{
    "mu-i",
    "mu(I) dense granular flow (Jop, Forterre & Pouliquen 2006): tau = mu(I) P, I = |gamma_dot| d / sqrt(P / rho_s)",
    {{"mu_s", "", 0.0, 0.0, 10.0, false, false, true, "friction coefficient at I -> 0 (tan of the angle of repose)"},
     {"mu_2", "", 0.0, 0.0, 10.0, false, false, true, "friction coefficient at I -> infinity (>= mu_s)"},
     {"inertial_number_scale", "", 0.279, 0.0, 10.0, true, false, false, "I0 (0.279 for glass beads, Jop et al.)"},
     {"grain_diameter", "m", 0.0, 0.0, 1.0, true, false, true, "grain diameter d"},
     {"solid_fraction", "", 0.6, 0.0, 1.0, true, false, false, "phi = rho0 / rho_s, the grains' share of the volume"},
     regularisation_spec()},
    {.yield_stress = true, .granular = true, .verlet_stable = false},
    [](const ParameterValues& v, real density) -> std::unique_ptr<Rheology> {
      if (v.at("mu_2") < v.at("mu_s"))
        throw std::invalid_argument("mu_2: must be >= mu_s (" + format_number(v.at("mu_s")) + ")");
      return std::make_unique<MuI>(v.at("mu_s"), v.at("mu_2"), v.at("inertial_number_scale"), v.at("grain_diameter"),
                                   density / v.at("solid_fraction"), v.at("regularisation"));
    },
};

}  // namespace runout::rheology
