// Newtonian fluid: mu_eff = mu; mu = 0 is inviscid (the stress pass is skipped).
#include "runout/engine/rheology.hpp"

namespace runout::rheology {
namespace {

class Newtonian final : public Rheology {
 public:
  explicit Newtonian(real viscosity) : mu_(viscosity) {}
  void effective_viscosity(std::span<const real>, std::span<const real>, std::span<real> mu_eff) const override {
    for (auto& v : mu_eff) v = mu_;
  }
  bool is_inviscid() const override { return mu_ == 0.0; }
  real viscosity_bound() const override { return mu_; }

 private:
  real mu_;
};

}  // namespace

extern const RheologyModel newtonian_model{
    "newtonian",
    "Newtonian fluid (water): mu_eff = mu",
    {{"viscosity", "Pa s", 0.0, 0.0, 1e8, false, false, false, "dynamic viscosity mu (0: inviscid)"}},
    {.yield_stress = false, .granular = false, .verlet_stable = true},
    [](const ParameterValues& v, real /*density*/) -> std::unique_ptr<Rheology> { return std::make_unique<Newtonian>(v.at("viscosity")); },
};

}  // namespace runout::rheology
