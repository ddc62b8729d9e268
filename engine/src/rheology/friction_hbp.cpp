// friction-HBP (thesis eq. 4.9): Herschel-Bulkley-Papanastasiou whose yield stress follows Mohr-Coulomb,
// tau_y = (1 - r_u) max(P, 0) sin(phi) + c cos(phi). P is the kernel-averaged pressure the solver hands the
// rheology: the mixture's total pressure. r_u, the pore-pressure ratio (Hungr 1995; DAN3D's frictional
// rheology, McDougall & Hungr 2004), is the share of it the pore fluid carries, so (1 - r_u) P is the effective
// stress that friction acts on: 0 for a dry material, rho_w / rho for a saturated one at hydrostatic pore pressure.
#include "laws.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::rheology {
namespace {

class FrictionHBP final : public Rheology {
 public:
  FrictionHBP(real consistency, real flow_index, real regularisation, real friction_angle_deg, real cohesion,
              real pore_pressure_ratio)
      : mu_(consistency),
        n_(flow_index),
        m_(regularisation),
        sin_phi_((1.0 - pore_pressure_ratio) * std::sin(friction_angle_deg * kPi / 180.0)),
        cos_phi_(std::cos(friction_angle_deg * kPi / 180.0)),
        cohesion_(cohesion) {}
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real> pressure,
                           std::span<real> mu_eff) const override {
    for (size_t k = 0; k < mu_eff.size(); ++k) {
      const real g = gamma_dot[k];
      const real p = pressure[k] > 0 ? pressure[k] : 0.0;
      const real tau_y = p * sin_phi_ + cohesion_ * cos_phi_;
      mu_eff[k] = power_law(mu_, n_, g) + tau_y * papanastasiou_factor(m_, g);
    }
  }
  // In simple shear the yield stress is (1 - r_u) P sin(phi): at a bed whose normal stress is P, the Coulomb
  // coefficient is (1 - r_u) sin(phi) (the infinite-slope threshold tan(slope) = sin(phi) of tests/engine, dry).
  real wall_friction_coefficient() const override { return sin_phi_; }
  real tensile_strength() const override {
    return sin_phi_ > 0 ? cohesion_ * cos_phi_ / sin_phi_ : std::numeric_limits<real>::infinity();
  }
  real yield_stress(real pressure) const override {
    return (pressure > 0 ? pressure : 0.0) * sin_phi_ + cohesion_ * cos_phi_;
  }
  real viscosity_bound() const override {
    return n_ == 1.0 && sin_phi_ == 0.0 && cohesion_ == 0.0 ? mu_ : Rheology::viscosity_bound();
  }

 private:
  real mu_, n_, m_;
  real sin_phi_;  // (1 - r_u) sin(phi): the friction on the total pressure
  real cos_phi_, cohesion_;
};

}  // namespace

extern const RheologyModel friction_hbp_model{
    "friction-hbp",
    "HBP with a Mohr-Coulomb yield stress tau_y = (1 - r_u) max(P, 0) sin(phi) + c cos(phi) (the study's model)",
    {consistency_spec(), flow_index_spec(), regularisation_spec(),
     {"friction_angle", "degrees", 0.0, 0.0, 90.0, false, true, true, "internal friction angle phi"},
     {"cohesion", "Pa", 0.0, 0.0, 1e7, false, false, false, "cohesion c"},
     {"pore_pressure_ratio", "", 0.0, 0.0, 1.0, false, true, false,
      "r_u: the pore fluid's share of the pressure (0 dry; rho_w / rho saturated at hydrostatic pore pressure)"}},
    {.yield_stress = true, .granular = true, .verlet_stable = false},
    [](const ParameterValues& v, real /*density*/) -> std::unique_ptr<Rheology> {
      return std::make_unique<FrictionHBP>(v.at("viscosity"), v.at("flow_index"), v.at("regularisation"),
                                           v.at("friction_angle"), v.at("cohesion"), v.at("pore_pressure_ratio"));
    },
};

}  // namespace runout::rheology
