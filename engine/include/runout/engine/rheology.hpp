#pragma once
// Rheologies: each maps (shear-rate magnitude, pressure) to an effective viscosity mu_eff, so that the
// deviatoric stress is tau = 2 mu_eff D with |gamma_dot| = sqrt(2 D':D') (simple shear u = g y gives
// |gamma_dot| = g and tau_xy = mu_eff g).
//
// A rheology is evaluated once per particle per force evaluation over a whole material batch (one virtual
// call per batch, none per pair). A new model is a new class deriving from Rheology plus one line in
// `rheology_registry()` (rheology.cpp).
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {

// Material parameters as a user writes them. Each rheology reads the ones it needs.
struct MaterialParams {
  std::string name;
  std::string rheology = "newtonian";
  real density = 1000.0;           // reference density rho0 [kg/m^3]
  real viscosity = 1e-3;           // consistency mu [Pa s^n] (dynamic viscosity when n = 1)
  real flow_index = 1.0;           // n [-]
  real regularisation = 100.0;     // Papanastasiou m [s]
  real yield_stress = 0.0;         // tau_y [Pa] (bingham, hbp)
  real friction_angle_deg = 0.0;   // phi [deg] (friction-hbp)
  real cohesion = 0.0;             // c [Pa] (friction-hbp)
};

// Regularisation shared by every rheology: the shear rate is floored before use (the power-law part
// diverges as |gamma_dot| -> 0 for n < 1, and tau_y/|gamma_dot| does for Bingham) and mu_eff is capped.
// The cap enters the viscous time-step limit, so it trades speed against how well resting material rests.
struct ViscosityLimits {
  real shear_rate_floor = 1e-6;  // [1/s]
  real max_viscosity = 1e300;    // [Pa s], set by the solver (explicit value or "auto")
};

class Rheology {
 public:
  virtual ~Rheology() = default;
  // mu_eff[k] for shear rate gamma_dot[k] (already floored) and pressure p[k].
  virtual void effective_viscosity(std::span<const real> gamma_dot, std::span<const real> pressure,
                                   std::span<real> mu_eff) const = 0;
  // Coulomb coefficient of the material's contact with a wall (0: none). When positive, the wall's shear on a
  // particle is the rheology at zero confining pressure (viscous and cohesive part) plus Coulomb friction,
  // coefficient times the normal force the wall exerts on the particle: the basal normal stress, which a thin
  // sheet's own SPH pressure does not carry (docs/design.md, "Basal friction").
  virtual real wall_friction_coefficient() const { return 0.0; }
  // Yield stress at pressure p (0 for fluids without one); used by reports and tests.
  virtual real yield_stress(real pressure) const { return 0.0; }
  // Whether the stress term can be skipped entirely (an inviscid fluid).
  virtual bool is_inviscid() const { return false; }
  // The largest isotropic tension the material carries [Pa]; the solver floors its pressure at minus this.
  // Liquids: unlimited (the equation of state's own). A Mohr-Coulomb material: c cot(phi), none when c = 0.
  virtual real tensile_strength() const { return std::numeric_limits<real>::infinity(); }
};

using RheologyFactory = std::function<std::unique_ptr<Rheology>(const MaterialParams&)>;

// name -> factory; the single place models are registered.
const std::map<std::string, RheologyFactory>& rheology_registry();
std::vector<std::string> rheology_names();
// Throws std::invalid_argument naming the field and the accepted range for bad parameters.
std::unique_ptr<Rheology> make_rheology(const MaterialParams& params);

// The models, exposed for unit tests.
class Newtonian final : public Rheology {
 public:
  explicit Newtonian(real viscosity) : mu_(viscosity) {}
  void effective_viscosity(std::span<const real>, std::span<const real>, std::span<real> mu_eff) const override;
  bool is_inviscid() const override { return mu_ == 0.0; }

 private:
  real mu_;
};

class Bingham final : public Rheology {
 public:
  Bingham(real viscosity, real yield_stress) : mu_(viscosity), tau_y_(yield_stress) {}
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real>,
                           std::span<real> mu_eff) const override;
  real yield_stress(real) const override { return tau_y_; }

 private:
  real mu_, tau_y_;
};

// Herschel-Bulkley-Papanastasiou (thesis eq. 4.4) with mu_eff = mu g^(n-1) + tau_y (1 - exp(-m g)) / g.
class HerschelBulkleyPapanastasiou : public Rheology {
 public:
  HerschelBulkleyPapanastasiou(real consistency, real flow_index, real regularisation, real yield_stress)
      : mu_(consistency), n_(flow_index), m_(regularisation), tau_y_(yield_stress) {}
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real> pressure,
                           std::span<real> mu_eff) const override;
  real yield_stress(real) const override { return tau_y_; }

 protected:
  real mu_, n_, m_, tau_y_;
};

// friction-HBP (thesis eq. 4.9): HBP whose yield stress follows Mohr-Coulomb,
// tau_y = max(P, 0) sin(phi) + c cos(phi).
class FrictionHBP final : public Rheology {
 public:
  FrictionHBP(real consistency, real flow_index, real regularisation, real friction_angle_deg, real cohesion);
  // In simple shear the yield stress is P sin(phi): at a bed whose normal stress is P, the Coulomb
  // coefficient is sin(phi) (the infinite-slope threshold tan(slope) = sin(phi) of tests/engine).
  real wall_friction_coefficient() const override { return sin_phi_; }
  real tensile_strength() const override {
    return sin_phi_ > 0 ? cohesion_ * cos_phi_ / sin_phi_ : std::numeric_limits<real>::infinity();
  }
  void effective_viscosity(std::span<const real> gamma_dot, std::span<const real> pressure,
                           std::span<real> mu_eff) const override;
  real yield_stress(real pressure) const override {
    return (pressure > 0 ? pressure : 0.0) * sin_phi_ + cohesion_ * cos_phi_;
  }

 private:
  real mu_, n_, m_, sin_phi_, cos_phi_, cohesion_;
};

}  // namespace runout
