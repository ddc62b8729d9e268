// Herschel-Bulkley-Papanastasiou (thesis eq. 4.4): mu_eff = mu g^(n-1) + tau_y (1 - exp(-m g)) / g, g = |gamma_dot|.
// The thesis' "original" model of a debris flow, a yield stress independent of pressure.
#include "laws.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::rheology {
namespace {

class HerschelBulkleyPapanastasiou final : public Rheology {
 public:
  HerschelBulkleyPapanastasiou(real consistency, real flow_index, real regularisation, real yield_stress)
      : mu_(consistency), n_(flow_index), m_(regularisation), tau_y_(yield_stress) {}
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real>,
                           std::span<real> mu_eff) const override {
    for (size_t k = 0; k < mu_eff.size(); ++k) {
      const real g = gamma_dot[k];
      mu_eff[k] = power_law(mu_, n_, g) + tau_y_ * papanastasiou_factor(m_, g);
    }
  }
  real yield_stress(real) const override { return tau_y_; }
  real viscosity_bound() const override {
    return n_ == 1.0 && tau_y_ == 0.0 ? mu_ : Rheology::viscosity_bound();
  }

 private:
  real mu_, n_, m_, tau_y_;
};

}  // namespace

extern const RheologyModel hbp_model{
    "hbp",
    "Herschel-Bulkley-Papanastasiou: mu_eff = mu |gamma_dot|^(n-1) + tau_y (1 - exp(-m |gamma_dot|)) / |gamma_dot|",
    {consistency_spec(), flow_index_spec(), regularisation_spec(),
     {"yield_stress", "Pa", 0.0, 0.0, 1e7, false, false, true, "yield stress tau_y"}},
    {.yield_stress = true, .granular = false, .verlet_stable = false},
    [](const ParameterValues& v, real /*density*/) -> std::unique_ptr<Rheology> {
      return std::make_unique<HerschelBulkleyPapanastasiou>(v.at("viscosity"), v.at("flow_index"),
                                                            v.at("regularisation"), v.at("yield_stress"));
    },
};

}  // namespace runout::rheology
