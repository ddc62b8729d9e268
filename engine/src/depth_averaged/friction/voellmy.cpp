// Voellmy basal resistance: tau_b = mu sigma_n + rho g |u|^2 / xi (Coulomb plus a turbulent drag; xi the
// turbulence coefficient [m/s^2]). A uniform sheet of thickness h on slope theta reaches
// |u| = sqrt(xi h (sin(theta) - mu cos(theta))).
#include "runout/engine/depth_averaged.hpp"

namespace runout::depth_averaged::friction {
namespace {

class Voellmy final : public BasalFriction {
 public:
  Voellmy(real mu, real xi, real gravity) : mu_(mu), g_over_xi_(gravity / xi) {}
  void shear_stress(std::span<const real> normal_stress, std::span<const real> speed, std::span<const real>,
                    std::span<real> tau) const override {
    for (size_t k = 0; k < tau.size(); ++k) tau[k] = mu_ * normal_stress[k] + g_over_xi_ * speed[k] * speed[k];
  }

 private:
  real mu_, g_over_xi_;
};

}  // namespace

extern const FrictionModel voellmy_friction{
    "voellmy",
    "Voellmy: tau_b = mu sigma_n + rho g |u|^2 / xi",
    {{"mu", "", 0.155, 0.0, 10.0, false, false, false, "Coulomb part mu"},
     {"xi", "m/s^2", 500.0, 0.0, 1e6, true, false, false, "turbulence coefficient xi"}},
    [](const ParameterValues& v, real gravity) -> std::unique_ptr<BasalFriction> {
      return std::make_unique<Voellmy>(v.at("mu"), v.at("xi"), gravity);
    },
};

}  // namespace runout::depth_averaged::friction
