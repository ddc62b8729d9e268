// Bingham plastic, unregularised: mu_eff = mu + tau_y / |gamma_dot| (the shear-rate floor and the solver's cap
// bound it).
#include "laws.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::rheology {
namespace {

class Bingham final : public Rheology {
 public:
  Bingham(real viscosity, real yield_stress) : mu_(viscosity), tau_y_(yield_stress) {}
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real>,
                           std::span<real> mu_eff) const override {
    for (size_t k = 0; k < mu_eff.size(); ++k) mu_eff[k] = mu_ + tau_y_ / gamma_dot[k];
  }
  real yield_stress(real) const override { return tau_y_; }
  real viscosity_bound() const override { return tau_y_ == 0.0 ? mu_ : Rheology::viscosity_bound(); }

 private:
  real mu_, tau_y_;
};

}  // namespace

extern const RheologyModel bingham_model{
    "bingham",
    "Bingham plastic: mu_eff = mu + tau_y / |gamma_dot|",
    {{"viscosity", "Pa s", 1e-3, 0.0, 1e8, false, false, false, "plastic viscosity mu"},
     {"yield_stress", "Pa", 0.0, 0.0, 1e7, false, false, true, "yield stress tau_y"}},
    {.yield_stress = true, .granular = false, .verlet_stable = false},
    [](const ParameterValues& v, real /*density*/) -> std::unique_ptr<Rheology> {
      return std::make_unique<Bingham>(v.at("viscosity"), v.at("yield_stress"));
    },
};

}  // namespace runout::rheology
