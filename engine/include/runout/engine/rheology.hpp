#pragma once
// Rheologies: each maps (shear-rate magnitude, pressure) to an effective viscosity mu_eff, so that the
// deviatoric stress is tau = 2 mu_eff D with |gamma_dot| = sqrt(2 D':D') (simple shear u = g y gives
// |gamma_dot| = g and tau_xy = mu_eff g).
//
// A rheology is evaluated once per particle per force evaluation over a whole material batch (one virtual
// call per batch, none per pair). Each model is one file under engine/src/rheology/ that defines its class and
// its RheologyModel (name, parameters, traits, factory), registered by one line in rheology/registry.hpp
// (docs/design.md, "How to add a rheology").
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "runout/engine/parameters.hpp"
#include "runout/engine/types.hpp"

namespace runout {

// A material as a user writes it: a name, a rheology chosen by name, the bulk density, and the rheology's own
// parameters by key (those absent take the model's default).
struct MaterialParams {
  std::string name;
  std::string rheology = "newtonian";
  real density = 1000.0;  // reference density rho0 [kg/m^3]
  ParameterValues parameters;

  MaterialParams& set(const std::string& key, real v) {
    parameters[key] = v;
    return *this;
  }
  // The value the model runs with: as given, else the model's default. Throws std::invalid_argument for a key
  // the model does not declare.
  real value(const std::string& key) const;
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
  // sheet's own SPH pressure does not carry (docs/design.md, "Basal friction"). When 0, the wall shears a
  // particle with the particle's own mu_eff (a no-slip wall of the same material).
  virtual real wall_friction_coefficient() const { return 0.0; }
  // Yield stress at pressure p (0 for fluids without one); used by reports and tests.
  virtual real yield_stress(real pressure) const { return 0.0; }
  // Whether the stress term can be skipped entirely (an inviscid fluid).
  virtual bool is_inviscid() const { return false; }
  // The largest isotropic tension the material carries [Pa]; the solver floors its pressure at minus this.
  // Liquids: unlimited (the equation of state's own). A Mohr-Coulomb material: c cot(phi), none when c = 0.
  virtual real tensile_strength() const { return std::numeric_limits<real>::infinity(); }
  // The largest mu_eff the law gives at any shear rate and pressure (infinite when only the cap bounds it):
  // the cost model's viscous time-step limit.
  virtual real viscosity_bound() const { return std::numeric_limits<real>::infinity(); }
};

// What the solver, the scene parser and the reports need to know of a model, without naming it.
struct RheologyTraits {
  bool yield_stress = false;   // rests below a yield stress: mu_eff reaches the cap where it rests
  bool granular = false;       // strength from confining pressure (frictional): carries no tension
  bool verlet_stable = false;  // Verlet's leapfrog carries it (tests/engine/verlet_test.cpp)
};

struct RheologyModel {
  std::string name;
  std::string doc;  // one line
  std::vector<ParameterSpec> parameters;
  RheologyTraits traits;
  // Values resolved against `parameters` (every key present, each in range) and the material's bulk density.
  // Throws std::invalid_argument "<key>: ..." for a combination the ranges cannot express.
  std::unique_ptr<Rheology> (*create)(const ParameterValues&, real density);
};

// Every registered model, in registration order (rheology/registry.hpp).
const std::vector<const RheologyModel*>& rheology_models();
// Throws std::invalid_argument naming the accepted names.
const RheologyModel& rheology_model(const std::string& name);
std::vector<std::string> rheology_names();
// The bulk density every material has, whatever its rheology.
const ParameterSpec& material_density_spec();
// Throws std::invalid_argument "materials.<name>.<field>: ..." naming the field and the accepted range.
std::unique_ptr<Rheology> make_rheology(const MaterialParams& params);

}  // namespace runout
