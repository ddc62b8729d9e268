// friction-HBP (thesis eq. 4.9): Herschel-Bulkley-Papanastasiou whose yield stress follows Mohr-Coulomb,
// tau_y = max(P, 0) sin(phi) + c cos(phi). P is the kernel-averaged pressure the solver hands the rheology.
#include "laws.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::rheology {
namespace {

class FrictionHBP final : public Rheology {
 public:
  FrictionHBP(real consistency, real flow_index, real regularisation, real friction_angle_deg, real cohesion)
      : mu_(consistency),
        n_(flow_index),
        m_(regularisation),
        sin_phi_(std::sin(friction_angle_deg * kPi / 180.0)),
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
  // In simple shear the yield stress is P sin(phi): at a bed whose normal stress is P, the Coulomb
  // coefficient is sin(phi) (the infinite-slope threshold tan(slope) = sin(phi) of tests/engine).
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
  real mu_, n_, m_, sin_phi_, cos_phi_, cohesion_;
};

}  // namespace

extern const RheologyModel friction_hbp_model{
    "friction-hbp",
    "HBP with a Mohr-Coulomb yield stress tau_y = max(P, 0) sin(phi) + c cos(phi) (the study's model)",
    {consistency_spec(), flow_index_spec(), regularisation_spec(),
     {"friction_angle", "degrees", 0.0, 0.0, 90.0, false, true, true, "internal friction angle phi"},
     {"cohesion", "Pa", 0.0, 0.0, 1e7, false, false, false, "cohesion c"}},
    {.yield_stress = true, .granular = true, .verlet_stable = false},
    [](const ParameterValues& v, real /*density*/) -> std::unique_ptr<Rheology> {
      return std::make_unique<FrictionHBP>(v.at("viscosity"), v.at("flow_index"), v.at("regularisation"),
                                           v.at("friction_angle"), v.at("cohesion"));
    },
};

}  // namespace runout::rheology
