// The numerics' descriptors and names (solver.hpp).
#include <stdexcept>

#include "runout/engine/solver.hpp"

namespace runout {
namespace {

template <class E>
E from_name(const std::string& name, const std::vector<std::string>& names, const char* what) {
  for (size_t k = 0; k < names.size(); ++k)
    if (names[k] == name) return static_cast<E>(k);
  std::string accepted;
  for (const auto& n : names) accepted += (accepted.empty() ? "" : ", ") + n;
  throw std::invalid_argument(std::string("unknown ") + what + " '" + name + "' (accepted: " + accepted + ")");
}

}  // namespace

const std::vector<ParameterSpec>& numerics_parameters() {
  static const std::vector<ParameterSpec> specs = {
      {"smoothing_ratio", "", numerics_default::smoothing_ratio, 1.0, 3.0, false, false, false, "h / dp"},
      {"verlet_reset_steps", "", numerics_default::verlet_reset_steps, 1, 1000, false, false, false,
       "Verlet: one Euler step every N steps", true},
      {"cfl", "", numerics_default::cfl, 0.0, 1.0, true, false, false,
       "dt = cfl min(dt_force, dt_acoustic), and <= the viscous limit 0.125 h^2 rho / mu_eff,max"},
      {"density_diffusion_delta", "", numerics_default::density_diffusion_delta, 0.0, 1.0, false, false, false,
       "density-diffusion coefficient delta"},
      {"artificial_viscosity", "", numerics_default::artificial_viscosity, 0.0, 10.0, false, false, false,
       "Monaghan alpha (0 switches it off)"},
      {"speed_of_sound_beta", "", 10.0, 1.0, 100.0, false, false, false, "beta in the default c0 = beta sqrt(g H)"},
      {"viscosity_cap_factor", "", numerics_default::viscosity_cap_factor, 0.0, 1e6, true, false, false,
       "with viscosity_cap auto: cap = factor x 0.125 h rho_min c0 / cfl"},
      {"viscous_tolerance", "", numerics_default::viscous_tolerance, 0.0, 0.1, true, false, false,
       "implicit viscosity: CG stops at this relative residual (M^-1-weighted)"},
      {"viscous_max_iterations", "", numerics_default::viscous_max_iterations, 1, 1e5, false, false, false,
       "implicit viscosity: CG iterations at most per step", true},
      {"shear_rate_floor", "1/s", numerics_default::shear_rate_floor, 0.0, 1e3, true, false, false,
       "floor on the shear-rate magnitude"},
      {"min_dt", "s", numerics_default::min_dt, 0.0, 1.0, true, false, false,
       "a time step below this stops the run"},
      {"max_dilatancy", "", numerics_default::max_dilatancy, 0.0, 0.5, false, false, false,
       "with density_floor: the floor stands this fraction under the tension-floor density"},
      {"neighbour_skin", "", numerics_default::neighbour_skin, 0.0, 1.0, false, false, false,
       "Verlet-list skin as a fraction of h: pair candidates within 2h + skin are kept until a pair may have "
       "closed in by the skin (0: the cells are scanned at every force evaluation)"},
      {"shifting_coefficient", "", numerics_default::shifting_coefficient, 0.0, 10.0, true, false, false,
       "with particle_shifting fickian: A in the shift -A h |v| dt grad C"},
  };
  return specs;
}

const ParameterSpec& numerics_parameter(const std::string& key) {
  for (const auto& p : numerics_parameters())
    if (p.key == key) return p;
  throw std::invalid_argument("numerics_parameter: '" + key + "' is not declared");
}

// In the enums' order.
const std::vector<std::string>& integrator_names() {
  static const std::vector<std::string> names = {"symplectic", "verlet"};
  return names;
}
const std::vector<std::string>& viscous_step_names() {
  static const std::vector<std::string> names = {"explicit", "implicit"};
  return names;
}
const std::vector<std::string>& density_diffusion_names() {
  static const std::vector<std::string> names = {"none", "molteni", "fourtakas"};
  return names;
}
const std::vector<std::string>& particle_shifting_names() {
  static const std::vector<std::string> names = {"none", "fickian"};
  return names;
}
const std::vector<std::string>& boundary_pressure_names() {
#define RUNOUT_WALL_MODEL_NAME(id, doc) #id,
  static const std::vector<std::string> names = {RUNOUT_WALL_MODELS(RUNOUT_WALL_MODEL_NAME)};
#undef RUNOUT_WALL_MODEL_NAME
  return names;
}
const std::vector<std::string>& boundary_pressure_docs() {
#define RUNOUT_WALL_MODEL_DOC(id, doc) doc,
  static const std::vector<std::string> docs = {RUNOUT_WALL_MODELS(RUNOUT_WALL_MODEL_DOC)};
#undef RUNOUT_WALL_MODEL_DOC
  return docs;
}
Integrator integrator_from_name(const std::string& name) {
  return from_name<Integrator>(name, integrator_names(), "integrator");
}
DensityDiffusion density_diffusion_from_name(const std::string& name) {
  return from_name<DensityDiffusion>(name, density_diffusion_names(), "density diffusion");
}
ViscousStep viscous_step_from_name(const std::string& name) {
  return from_name<ViscousStep>(name, viscous_step_names(), "viscous step");
}
ParticleShifting particle_shifting_from_name(const std::string& name) {
  return from_name<ParticleShifting>(name, particle_shifting_names(), "particle shifting");
}
BoundaryPressure boundary_pressure_from_name(const std::string& name) {
  return from_name<BoundaryPressure>(name, boundary_pressure_names(), "boundary pressure");
}

}  // namespace runout
