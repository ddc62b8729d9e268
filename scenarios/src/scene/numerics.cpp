// The numerics section: the engine's plain numbers (numerics_parameters()), the named choices, and the
// numbers whose defaults the scene computes (scene_numerics_fields()).
#include "readers.hpp"

#include <algorithm>

#include "runout/engine/kernels.hpp"
#include "runout/engine/rheology.hpp"

namespace runout {

const std::vector<FieldSpec>& scene_numerics_fields() {
  static const std::vector<FieldSpec> fields = {
      number_field({"speed_of_sound", "m/s", 0.0, 0.0, 1e5, true, false, false, "c0 of the Tait equation of state"}, 0,
                   "beta max(sqrt(g H), inflow speed; on terrain sqrt(2 g E))"),
      number_field({"depth_scale", "m", 0.0, 0.0, 1e5, true, false, false, "H in the default c0 = beta sqrt(g H)"}, 0,
                   "fluid top to the lowest particle (terrain: the release depth)"),
      number_field({"viscosity_cap", "Pa s", 0.0, 0.0, 1e12, true, false, false,
                    "upper bound on mu_eff, or \"auto\" (the viscous time step's bound)"},
                   0, "\"auto\""),
      number_field({"boundary_density", "kg/m3", 0.0, 0.0, 1e5, true, false, false, "density of wall particles"}, 0,
                   "the first material's density"),
  };
  return fields;
}

namespace {
FieldSpec choice_field(const std::string& key, const std::string& doc, const std::string& default_text) {
  FieldSpec f = shaped_field(key, "string", doc, false);
  f.default_text = default_text;
  return f;
}
}  // namespace

const std::vector<FieldSpec>& numerics_choice_fields() {
  static const std::vector<FieldSpec> fields = {
      choice_field("kernel", "the smoothing kernel", kernel_names().front()),
      choice_field("integrator", "the time integrator", integrator_names().front()),
      choice_field("density_diffusion", "the density-diffusion term", density_diffusion_names().back()),
      choice_field("viscosity", "how the viscous stress is integrated: explicit (mu_eff capped) or implicit (CG)",
                   "explicit; implicit with a yield-stress material and the symplectic integrator"),
      choice_field("boundary_pressure", "how wall particles get their pressure",
                   "dbc; extrapolated with inlets or a granular material"),
      [] {
        FieldSpec f = choice_field("density_floor", "floor the density under rho0 (granular materials)",
                                   "false; true with a granular material");
        f.shape = "boolean";
        return f;
      }(),
      choice_field("particle_shifting", "move particles down their concentration gradient (Lind et al. 2012)",
                   "none; fickian with a granular material"),
  };
  return fields;
}

namespace scene_reader {
namespace {

const ParameterSpec& scene_numeric(const std::string& key) {
  return field_spec(scene_numerics_fields(), key).parameters.front();
}

const std::string& default_choice(const std::string& key) { return field_spec(numerics_choice_fields(), key).default_text; }

// With one, the numerics default to GranularDefaults (scene.hpp).
template <int D>
bool has_granular_material(const Build<D>& b) {
  for (const auto& m : b.setup.materials)
    if (rheology_model(m.rheology).traits.granular) return true;
  return false;
}

Fields numerics_fields(const json& j) {
  std::set<std::string> keys;
  for (const auto& p : numerics_parameters()) keys.insert(p.key);
  for (const auto& f : scene_numerics_fields()) keys.insert(f.key);
  for (const auto& f : numerics_choice_fields()) keys.insert(f.key);
  return Fields(j.contains("numerics") ? j["numerics"] : json::object(), "numerics", keys);
}

// c0: explicit, or beta sqrt(g H) with H the depth scale (default: fluid top to the lowest particle).
// On terrain the lowest particle is far down the valley, not under the flow. There the speed scale is the
// energy line's: a block sliding at the travel angle reaches sqrt(2 g E) with E the energy height, and
// c0 = beta max(sqrt(g d), sqrt(2 g E)) keeps the Mach number under 1/beta (conservative: the real flow
// loses more than the travel angle says). An explicit speed_of_sound trades that margin for speed.
template <int D>
real speed_of_sound(const Build<D>& b, const Fields& num) {
  const real dp = b.dp;
  const real default_depth =
      b.tmodel ? std::max<real>(b.tmodel->release_depth, dp) : std::max(b.fluid_top - b.bottom, dp);
  const ParameterSpec& h = scene_numeric("depth_scale");
  const real depth_scale = num.number_or(h.key, default_depth, h.lo, h.hi, h.lo_open, h.hi_open);
  const real beta = read_parameter(num, numerics_parameter("speed_of_sound_beta"));
  real speed_scale = std::sqrt(std::max(b.g_mag, 1e-3) * depth_scale);
  if (b.tmodel && !num.has("depth_scale"))
    speed_scale = std::max(speed_scale, std::sqrt(2.0 * std::max(b.g_mag, 1e-3) * b.tmodel->max_energy_height));
  speed_scale = std::max(speed_scale, b.inlet_speed_max);  // inflow faster than its sqrt(g H)
  const ParameterSpec& c = scene_numeric("speed_of_sound");
  return num.has(c.key) ? num.number(c.key, c.lo, c.hi, c.lo_open, c.hi_open) : beta * speed_scale;
}

void read_viscosity_cap(const Fields& num, SolverConfig& cfg) {
  if (!num.has("viscosity_cap")) return;
  const json& cap = num.raw("viscosity_cap");
  if (cap.is_string()) {
    Fields::check_choice(num.at("viscosity_cap"), cap.get<std::string>(), {"auto"});
    cfg.max_viscosity = 0;
  } else {
    const ParameterSpec& p = scene_numeric("viscosity_cap");
    cfg.max_viscosity = Fields::check_number(cap, num.at("viscosity_cap"), p.lo, p.hi, p.lo_open, p.hi_open);
  }
}

// A yield-stress material rests at mu_eff = m tau_y, far above what an explicit step carries: it defaults to the
// implicit step, which needs no cap (docs/design.md, "Implicit viscous step"; measured there). Verlet has no
// implicit variant, and refuses yield-stress materials anyway (check_verlet). The cap factor sizes the explicit
// step's cap only: given with the implicit step it would be silently unused, so it is refused.
template <int D>
void read_viscous_step(const Build<D>& b, const Fields& num, SolverConfig& cfg) {
  bool yield_stress = false;
  for (const auto& m : b.setup.materials) yield_stress = yield_stress || rheology_model(m.rheology).traits.yield_stress;
  const bool implicit_default = yield_stress && cfg.integrator == Integrator::symplectic;
  cfg.viscous_step = viscous_step_from_name(
      num.string_or("viscosity", viscous_step_names()[implicit_default ? 1 : 0], viscous_step_names()));
  cfg.viscous_tolerance = read_parameter(num, numerics_parameter("viscous_tolerance"));
  cfg.viscous_max_iterations = static_cast<int>(read_parameter(num, numerics_parameter("viscous_max_iterations")));
  cfg.viscosity_cap_factor = read_parameter(num, numerics_parameter("viscosity_cap_factor"));
  if (cfg.viscous_step != ViscousStep::implicit) return;
  if (cfg.integrator != Integrator::symplectic)
    throw SceneError(num.at("viscosity"), "implicit needs the symplectic integrator (accepted here: explicit)");
  if (num.has("viscosity_cap_factor"))
    throw SceneError(num.at("viscosity_cap_factor"),
                     "sizes the explicit step's viscosity cap: remove it, or set numerics.viscosity to explicit "
                     "(the implicit step needs no cap; numerics.viscosity_cap in Pa s still bounds mu_eff)");
}

// Inlets need walls without memory: a DBC wall particle under a buffer that moves over it gains density
// from the one-sided inflow at the plane and never loses it (its density is floored at rho0), until it
// throws the new flow off the bed (measured: tests/engine/inlet_test.cpp detaches at t < 0.2 s with dbc).
template <int D>
void read_walls(const Build<D>& b, const Fields& num, SolverConfig& cfg) {
  const std::string bp_default =
      b.setup.inlets.empty() && !has_granular_material(b) ? "dbc" : GranularDefaults::boundary_pressure;
  cfg.boundary_pressure =
      boundary_pressure_from_name(num.string_or("boundary_pressure", bp_default, boundary_pressure_names()));
  if (!b.setup.inlets.empty() && cfg.boundary_pressure == BoundaryPressure::dbc)
    throw SceneError("numerics.boundary_pressure", "must be 'extrapolated' in a scene with inlets (accepted: extrapolated)");
  const ParameterSpec& p = scene_numeric("boundary_density");
  cfg.boundary_density = num.number_or(p.key, b.setup.materials[0].density, p.lo, p.hi, p.lo_open, p.hi_open);
}

// Verlet's leapfrog (v_{n+1} = v_{n-1} + 2 dt a_n) has a computational mode that a viscous force taken at
// level n drives unstably; the Euler step every verlet_reset_steps holds it down for a liquid's viscosity,
// not for a viscoplastic material, whose mu_eff sits at the cap (at the viscous time-step limit) wherever
// it rests. Measured: a friction column blew up within 5 ms, a Bingham channel reached Mach 1.3, a plain
// HBP column Mach 0.43 against 0.05 (docs/design.md, "Time stepping and guards").
void check_verlet(const std::vector<MaterialParams>& materials, const Fields& num) {
  for (const auto& m : materials)
    if (!rheology_model(m.rheology).traits.verlet_stable)
      throw SceneError(num.at("integrator"),
                       "verlet cannot carry material '" + m.name + "' (" + m.rheology +
                           "): its effective viscosity reaches the cap where it rests, and Verlet's leapfrog is "
                           "unstable under it; use symplectic (accepted here: symplectic)");
}

}  // namespace

template <int D>
void read_numerics(Build<D>& b) {
  SolverConfig& cfg = b.cfg;
  const Fields num = numerics_fields(b.j);
  auto numeric = [&num](const char* key) { return read_parameter(num, numerics_parameter(key)); };
  cfg.kernel = kernel_from_name(num.string_or("kernel", kernel_names().front(), kernel_names()));
  cfg.smoothing_length = numeric("smoothing_ratio") * b.dp;
  cfg.integrator = integrator_from_name(num.string_or("integrator", default_choice("integrator"), integrator_names()));
  cfg.verlet_reset_steps = static_cast<int>(numeric("verlet_reset_steps"));
  cfg.cfl = numeric("cfl");
  cfg.density_diffusion = density_diffusion_from_name(num.string_or("density_diffusion", default_choice("density_diffusion"), density_diffusion_names()));
  cfg.density_diffusion_delta = numeric("density_diffusion_delta");
  cfg.artificial_viscosity = numeric("artificial_viscosity");
  cfg.speed_of_sound = speed_of_sound(b, num);
  read_viscosity_cap(num, cfg);
  read_viscous_step(b, num, cfg);
  cfg.shear_rate_floor = numeric("shear_rate_floor");
  cfg.min_dt = numeric("min_dt");
  cfg.neighbour_skin = numeric("neighbour_skin");
  const bool granular = has_granular_material(b);
  cfg.density_floor = num.boolean_or("density_floor", granular && GranularDefaults::density_floor);
  cfg.max_dilatancy =
      granular && cfg.density_floor && !num.has("max_dilatancy") ? GranularDefaults::max_dilatancy : numeric("max_dilatancy");
  if (num.has("max_dilatancy") && !cfg.density_floor)
    throw SceneError(num.at("max_dilatancy"), "sets how far under rho0 the density floor stands: needs numerics.density_floor = true");
  read_walls(b, num, cfg);
  cfg.particle_shifting = particle_shifting_from_name(num.string_or(
      "particle_shifting", granular ? GranularDefaults::particle_shifting : "none", particle_shifting_names()));
  cfg.shifting_coefficient = numeric("shifting_coefficient");
  if (num.has("shifting_coefficient") && cfg.particle_shifting == ParticleShifting::none)
    throw SceneError(num.at("shifting_coefficient"),
                     "sizes the particle shift: needs numerics.particle_shifting = fickian");
  if (cfg.integrator == Integrator::verlet) check_verlet(b.setup.materials, num);
}

template void read_numerics<2>(Build<2>&);
template void read_numerics<3>(Build<3>&);

}  // namespace scene_reader
}  // namespace runout
