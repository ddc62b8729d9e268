// Coulomb basal friction: tau_b = mu sigma_n (a dry granular bed; mu = tan(delta), delta the bed friction angle).
#include "runout/engine/depth_averaged.hpp"

namespace runout::depth_averaged::friction {
namespace {

class Coulomb final : public BasalFriction {
 public:
  explicit Coulomb(real mu) : mu_(mu) {}
  void shear_stress(std::span<const real> normal_stress, std::span<const real>, std::span<const real>,
                    std::span<real> tau) const override {
    for (size_t k = 0; k < tau.size(); ++k) tau[k] = mu_ * normal_stress[k];
  }

 private:
  real mu_;
};

}  // namespace

extern const FrictionModel coulomb_friction{
    "coulomb",
    "Coulomb: tau_b = mu sigma_n",
    {{"mu", "", 0.4, 0.0, 10.0, false, false, false, "friction coefficient mu = tan(delta)"}},
    [](const ParameterValues& v, real /*gravity*/) -> std::unique_ptr<BasalFriction> {
      return std::make_unique<Coulomb>(v.at("mu"));
    },
};

}  // namespace runout::depth_averaged::friction
