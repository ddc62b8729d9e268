#pragma once
// Weakly compressible SPH solver (thesis ch. 2 and eq. 4.1), 2D and 3D from one template.
//
// Data layout: structure of arrays, fluid and boundary particles in separate sets. Fluid particles are
// re-sorted by cell every step; boundary particles never move and are re-sorted only when the set of wall
// tiles alive changes (a wall source's tiles are laid ahead of the flow and dropped behind it). Work is done
// only in cells holding fluid and in the boundary cells next to them.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "runout/engine/geometry.hpp"
#include "runout/engine/kernels.hpp"
#include "runout/engine/parameters.hpp"
#include "runout/engine/rheology.hpp"
#include "runout/engine/state_io.hpp"
#include "runout/engine/types.hpp"
#include "runout/engine/wall_models.hpp"
#include "runout/engine/wall_source.hpp"

namespace runout {

enum class Integrator { symplectic, verlet };
enum class DensityDiffusion { none, molteni, fourtakas };
// How the viscous stress is integrated: explicitly in the momentum pass, with mu_eff capped so that the viscous
// time-step limit stays near the acoustic one, or by a backward-Euler step solved with conjugate gradients after
// the corrector (implicit_viscosity.cpp), with mu_eff uncapped unless the scene sets a cap in Pa s.
enum class ViscousStep { explicit_capped, implicit };
// Particle shifting: none, or Lind et al.'s (2012) Fickian shift (engine/src/solver/shifting.cpp).
enum class ParticleShifting { none, fickian };

// Wall contact: a fluid particle closer than kWallContact dp to a wall particle loses the velocity component
// towards the wall. A resting particle sits dp above the bed lattice and 0.9 dp from the next terrain column's
// top particle on a 30 deg staircase; every face of the lattice (0.71 dp from its corners) is covered.
constexpr real kWallContact = 0.75;

// The plain-number numerics' defaults, declared once: SolverConfig's members start from them and
// numerics_parameters() (the scene's defaults, its schema and docs/scene-format.md) gives them.
namespace numerics_default {
inline constexpr real smoothing_ratio = 1.5;  // h / dp
inline constexpr int verlet_reset_steps = 40;
inline constexpr real cfl = 0.2;
inline constexpr real density_diffusion_delta = 0.1;
inline constexpr real artificial_viscosity = 0.0;
inline constexpr real viscosity_cap_factor = 1.0;
inline constexpr real viscous_tolerance = 1e-6;
inline constexpr int viscous_max_iterations = 1000;
inline constexpr real shear_rate_floor = 1e-6;  // [1/s]
inline constexpr real min_dt = 1e-8;            // [s]
inline constexpr real max_dilatancy = 0.0;
inline constexpr real neighbour_skin = 0.3;
inline constexpr real shifting_coefficient = 2.0;  // Lind et al. (2012); DualSPHysics' ShiftCoef -2
}  // namespace numerics_default

struct SolverConfig {
  real dp = 0.01;                   // initial particle spacing [m]
  real smoothing_length = numerics_default::smoothing_ratio * 0.01;  // h [m], at the default dp
  KernelKind kernel = KernelKind::wendland;
  real speed_of_sound = 20.0;       // c0 [m/s], same for every material
  real eos_gamma = 7.0;
  real cfl = numerics_default::cfl;
  Integrator integrator = Integrator::symplectic;
  // Verlet: one Euler step every N steps (thesis eq. 2.24)
  int verlet_reset_steps = numerics_default::verlet_reset_steps;
  DensityDiffusion density_diffusion = DensityDiffusion::fourtakas;
  real density_diffusion_delta = numerics_default::density_diffusion_delta;
  real artificial_viscosity = numerics_default::artificial_viscosity;  // Monaghan alpha; 0 switches the term off
  // Effective-viscosity cap [Pa s]. <= 0 means "auto": viscosity_cap_factor times the viscosity at which
  // the viscous time-step limit equals the acoustic one (0.125 h rho c0 / cfl).
  real max_viscosity = 0.0;
  real viscosity_cap_factor = numerics_default::viscosity_cap_factor;
  real shear_rate_floor = numerics_default::shear_rate_floor;  // [1/s]
  ViscousStep viscous_step = ViscousStep::explicit_capped;
  // Implicit step: CG stops when the M^-1-weighted residual is under this fraction of the right-hand side's
  // (docs/design.md, "Implicit viscous step"), or after viscous_max_iterations.
  real viscous_tolerance = numerics_default::viscous_tolerance;
  int viscous_max_iterations = numerics_default::viscous_max_iterations;
  real min_dt = numerics_default::min_dt;  // a step below this stops the run [s]
  // Verlet-list skin as a fraction of h: the cells are sorted and scanned for pair candidates within
  // 2h + skin, kept until a pair may have closed in by the skin; 0 scans them at every evaluation.
  real neighbour_skin = numerics_default::neighbour_skin;
  // Keep a material's fluid density at or above the density where the equation of state reaches its tension
  // floor (rho0 for cohesionless friction-HBP; liquids, without a floor, are untouched): see step().
  bool density_floor = false;
  // How far under that density the floor stands, as a fraction: 0.1 lets a granular material dilate 10 %
  // (loose against dense random packing) before its density is held.
  real max_dilatancy = numerics_default::max_dilatancy;
  // Fickian particle shifting (shifting.cpp): each step moves a particle down the gradient of its particle
  // concentration by A h |v| dt grad C, off at a free surface.
  ParticleShifting particle_shifting = ParticleShifting::none;
  real shifting_coefficient = numerics_default::shifting_coefficient;
  std::array<real, 3> gravity{0.0, 0.0, -9.81};  // first D components are used
  real boundary_density = 1000.0;   // reference density of boundary particles [kg/m^3]
  BoundaryPressure boundary_pressure = BoundaryPressure::dbc;
  // Domain: leaving through a closed face is a leak (error), through an open face an outflow (removed and
  // counted). A periodic axis wraps; the vertical top is always open without removal.
  std::array<real, 3> domain_min{-1e30, -1e30, -1e30};
  std::array<real, 3> domain_max{1e30, 1e30, 1e30};
  std::array<bool, 3> periodic{false, false, false};
  std::array<std::array<bool, 2>, 3> outflow{};  // outflow[d][0] low face, [1] high face
};

// The numerics a scene sets as plain numbers with a fixed default, declared once: the scene parser, the schema
// and the docs' numerics table read them (engine/src/solver/numerics.cpp). Throws std::invalid_argument for an
// undeclared key.
const std::vector<ParameterSpec>& numerics_parameters();
const ParameterSpec& numerics_parameter(const std::string& key);
// The named choices of the numerics, by the names a scene gives them.
const std::vector<std::string>& integrator_names();
const std::vector<std::string>& density_diffusion_names();
const std::vector<std::string>& viscous_step_names();
const std::vector<std::string>& particle_shifting_names();
Integrator integrator_from_name(const std::string& name);
DensityDiffusion density_diffusion_from_name(const std::string& name);
ViscousStep viscous_step_from_name(const std::string& name);
ParticleShifting particle_shifting_from_name(const std::string& name);

namespace solver_detail {
template <int D>
struct PassContext;  // engine/src/solver/pass_context.hpp
}

// Particle storage: one vector per component (SoA).
template <int D>
struct ParticleArrays {
  std::array<std::vector<real>, D> pos, vel;
  std::vector<real> rho, mass;
  std::vector<uint16_t> material;  // fluid: material index; boundary: unused (0)
  std::vector<uint32_t> tag;       // structure tag (boundary) or source block (fluid)
  std::vector<uint32_t> id;        // stable id, for error messages and outputs

  size_t size() const { return rho.size(); }
  void add(const Vec<D>& p, real density, real m, uint16_t mat, uint32_t tg);
  Vec<D> position(size_t i) const {
    Vec<D> p;
    for (int d = 0; d < D; ++d) p[d] = pos[d][i];
    return p;
  }
  Vec<D> velocity(size_t i) const {
    Vec<D> v;
    for (int d = 0; d < D; ++d) v[d] = vel[d][i];
    return v;
  }
};

// A velocity inlet (an inflow boundary): flow enters across a vertical plane through an opening of lanes
// (3D: side by side at spacing dp along `across`; 2D: one), each over its own floor, at a prescribed speed
// along `normal` that may vary in time (a hydrograph). Upstream of the plane a buffer of layers of particles
// moves at that speed along its lane's floor, with the hydrostatic density of a free surface `depth` above the
// floor; they give the flow beyond the plane full kernel support. A buffer particle that crosses the plane
// becomes flow and a new one enters at the back of the buffer, so the volume rate is the horizontal speed x
// the opening's area exactly, one particle at a time. Flow that runs back into the buffer is removed (counted
// as outflow). A flume's inlet has one flat floor; a terrain's follows the ground under each lane.
template <int D>
struct InletSpec {
  std::string name;
  Vec<D> normal = Vec<D>::Unit(0);  // unit, horizontal: the way the flow enters
  Vec<D> origin = Vec<D>::Zero();   // on the plane: where the first lane starts (its height is not used)
  Vec<D> across = Vec<D>::Zero();   // 3D: unit, horizontal, across `normal`; lane k's centre at (k + 1/2) dp along it
  std::vector<real> floor;          // per lane: the floor's height where it meets the plane [m]
  std::vector<real> slope;          // per lane: the floor's rise per metre along `normal` (0: flat)
  real depth = 0;                   // the opening's height above the floor [m]
  std::vector<std::array<real, 2>> speed;  // (t [s], speed [m/s]) pairs, increasing t; linear between, held after
  uint16_t material = 0;
  real speed_at(real t) const;
  size_t lanes() const { return floor.size(); }
  // Signed distance of p downstream of the plane [m].
  real along(const Vec<D>& p) const { return (p - origin).dot(normal); }
  // The lane over which p lies (clamped to the opening); 0 in 2D.
  size_t lane_of(const Vec<D>& p, real dp) const;
  real floor_at(size_t lane, real s) const { return floor[lane] + slope[lane] * s; }
  // The buffer's direction of motion over a lane: horizontal speed 1 along `normal`, rising with the floor.
  Vec<D> motion(size_t lane) const {
    Vec<D> v = normal;
    v[D - 1] = slope[lane];
    return v;
  }
  // Particles across the opening: lanes x whole layers of dp in `depth`; the area they stand for [m^(D-1)].
  int layers_in_depth(real dp) const;
  real opening_area(real dp) const;
};

// Layers of an inlet's buffer: enough that a particle at the plane has full kernel support behind it.
int inlet_buffer_layers(const SolverConfig& config);

// What a scene hands the solver.
template <int D>
struct SceneSetup {
  static constexpr int kDim = D;
  SolverConfig config;
  std::vector<MaterialParams> materials;
  ParticleArrays<D> fluid;
  ParticleArrays<D> boundary;
  std::vector<LeakRegion<D>> leak_regions;
  std::vector<InletSpec<D>> inlets;
  // Wall particles laid near the flow only (a terrain's bed), besides the `boundary` ones, which always exist.
  std::shared_ptr<const WallSource<D>> wall_source;
  // The wall's normal at each `boundary` particle, one each or none; those not given (none, or a zero vector)
  // are estimated from the arrangement of the particles not given (wall_normals.cpp). The extrapolated wall
  // pressure's hydrostatic term acts along it.
  std::vector<Vec<D>> boundary_normals;
  // Most particles (fluid and boundary) alive at once; 0: no limit. Checked whenever wall tiles are laid.
  long max_particles = 0;
};

struct StepStats {
  real dt = 0, dt_force = 0, dt_acoustic = 0, dt_viscous = 0;
  real max_speed = 0;
  real max_effective_viscosity = 0;
  size_t active_boundary = 0;  // boundary particles that did work this step
  int viscous_iterations = 0;  // implicit viscous step: CG iterations this step
  real viscous_residual = 0;   // and the relative residual it stopped at
};

// The implicit viscous step over a run: how hard the solves were (one at the predictor, one at the corrector).
struct ViscousSolveSummary {
  long solves = 0, iterations = 0, max_iterations = 0, unconverged = 0;  // two solves a step
  real max_residual = 0;
};

// Flow mass per material: current = initial + inflow - outflow (inlet buffers are not flow until they
// cross their plane).
struct MassBalance {
  std::vector<long double> initial, current, outflow, inflow;  // per material [kg]
  long double total_initial() const;
  long double total_current() const;
  long double total_outflow() const;
  long double total_inflow() const;
};

struct EnergySummary {
  real kinetic = 0;            // [J]
  real potential_released = 0; // PE(0) - PE(t) over fluid, outflow and inflow at their crossing included [J]
  real inflow_kinetic = 0;     // kinetic energy inlets brought in, at their planes [J]
};

template <int D>
class Solver {
 public:
  explicit Solver(SceneSetup<D> setup);
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  // One time step; throws SimulationError on NaN/Inf, dt under the floor, or a leak.
  const StepStats& step();

  real time() const { return record_.time; }
  long steps() const { return record_.steps; }
  const SolverConfig& config() const { return config_; }
  real max_viscosity() const { return max_viscosity_; }
  const std::vector<MaterialParams>& materials() const { return materials_; }
  const ParticleArrays<D>& fluid() const { return fluid_; }
  const ParticleArrays<D>& boundary() const { return boundary_; }
  const std::vector<real>& fluid_pressure() const { return fluid_fields_.pressure; }
  const std::vector<real>& fluid_effective_viscosity() const { return fluid_fields_.mu_eff; }
  const std::vector<real>& fluid_shear_rate() const { return fluid_fields_.shear_rate; }
  const std::vector<real>& boundary_pressure() const { return wall_fields_.pressure; }
  // The wall's unit normal at each boundary particle (its sign is arbitrary; zero where none could be found).
  const std::array<std::vector<real>, D>& boundary_normal() const { return wall_fields_.normal; }
  const StepStats& last_step() const { return record_.stats; }
  // Wall particles: the most alive at once, all the scene describes (the fixed ones and every tile of the wall
  // source), and a counter that changes whenever boundary() is rebuilt (its indices are then invalid).
  size_t boundary_peak() const { return boundary_peak_; }
  uint64_t boundary_described() const;
  uint64_t boundary_generation() const { return boundary_generation_; }
  // Removes these fluid particles (indices into fluid()) as outflow, at once, for a region the caller models
  // no further (a terrain corridor's edge): their mass goes to the outflow balance, as through an open domain
  // face. The remaining particles are re-sorted: indices held before the call are invalid after it.
  void remove_as_outflow(const std::vector<size_t>& indices);
  // Fluid particle ids are below this (inlets add particles with new ids as the run goes).
  uint32_t id_bound() const { return next_id_; }
  const std::vector<InletSpec<D>>& inlets() const { return inlets_; }
  // True for a particle of an inlet's buffer (not flow yet: not in the mass balance nor the energies).
  static bool is_inlet_buffer(uint32_t fluid_tag) { return (fluid_tag & kInletBufferBit) != 0; }
  static constexpr uint32_t kInletBufferBit = 0x80000000u;  // on a fluid particle's tag: the rest is the inlet index

  MassBalance mass_balance() const;
  EnergySummary energy() const;
  real max_mach() const { return record_.max_mach; }
  real min_dt_seen() const { return record_.min_dt_seen; }
  const ViscousSolveSummary& viscous_solves() const { return record_.viscous; }
  // How often the cells were scanned for pairs: every evaluation without a neighbour skin, after each sort
  // with one.
  long neighbour_list_builds() const;
  // The pairs within the kernel support at the current positions that the next step's first evaluation would
  // miss (a brute-force check of the Verlet-list bookkeeping, for tests): 0 unless it is wrong.
  size_t missing_neighbour_pairs() const;

  // The run's state (particles, the wall tiles alive and the walls' densities, balances, clocks), for a
  // checkpoint (solver/checkpoint.cpp): load_state on a solver built from the same setup continues exactly as
  // the saved one would have (bit for bit on one thread). load_state throws std::runtime_error for a
  // checkpoint of another setup.
  void save_state(StateWriter& out) const;
  void load_state(StateReader& in);

  // Evaluates accelerations and density rates at the current state without advancing (tests, monitors).
  void evaluate_rates();
  const std::array<std::vector<real>, D>& fluid_acceleration() const { return fluid_fields_.acc; }
  const std::vector<real>& fluid_density_rate() const { return fluid_fields_.drho; }
  // DBC continuity rate of boundary particles (0 for those with no flow near them).
  const std::vector<real>& boundary_density_rate() const { return wall_fields_.drho; }

 private:
  // Per fluid particle, what an evaluation works out (resized with the fluid at each sort).
  struct FluidFields {
    std::array<std::vector<real>, D> acc;
    std::vector<real> drho, pressure, mu_eff, shear_rate;
    std::vector<real> yield_pressure;  // kernel-averaged pressure the rheology's yield stress sees
    std::vector<real> mu_wall;         // viscosity of the wall side of fluid-wall pairs (friction rheologies: at p = 0)
    std::vector<real> zero_pressure;
    std::array<std::vector<real>, D> contact_normal;  // wall normal of particles in wall contact, else 0
    void resize(size_t n);
  };
  // Per wall particle, in the boundary's order: the wall's unit normal, its pressure and (DBC) density rate.
  struct WallFields {
    std::array<std::vector<real>, D> normal;
    std::vector<real> pressure, drho;
  };
  // What a step starts from: the predictor-corrector's start of step (symplectic) or the previous step (Verlet).
  struct StepStart {
    std::array<std::vector<real>, D> pos, vel;
    std::vector<real> rho, boundary_rho;
  };
  // The run's clock and what it has seen.
  struct RunRecord {
    real time = 0;
    long steps = 0;
    real max_mach = 0;
    real min_dt_seen = 1e300;
    StepStats stats;
    ViscousSolveSummary viscous;
  };
  // Mass and energy balances.
  struct Balances {
    MassBalance mass;
    real potential_initial = 0;
    real potential_outflow = 0;  // PE(0) contribution of removed particles at their removal point
    real kinetic_inflow = 0;
  };

  struct Impl;  // cells, pair lists, the passes' buffers, wall tiles (engine/src/solver/impl.hpp)
  std::unique_ptr<Impl> impl_;
  // The setup, fixed for the run.
  SolverConfig config_;
  std::vector<MaterialParams> materials_;
  std::vector<std::unique_ptr<Rheology>> rheologies_;
  std::vector<LeakRegion<D>> leak_regions_;
  std::vector<InletSpec<D>> inlets_;
  std::shared_ptr<const WallSource<D>> wall_source_;
  long max_particles_ = 0;
  real max_viscosity_ = 0;  // the mu_eff cap in force
  // The particles and what goes with them.
  ParticleArrays<D> fluid_, boundary_;
  FluidFields fluid_fields_;
  WallFields wall_fields_;
  StepStart saved_;
  uint32_t next_id_ = 0;
  std::vector<char> outflow_marked_;  // per fluid particle, set by remove_as_outflow; empty when none is
  size_t boundary_peak_ = 0;
  uint64_t boundary_generation_ = 0;
  RunRecord record_;
  Balances balance_;

  void set_up_cells();  // the cell grid, once (solver.cpp)
  void sort_and_build_cells();
  bool removed_at_sort(const Vec<D>& p, uint32_t tag) const;
  bool leaves_sorted_cells(size_t i) const;
  // pair_lists.cpp: the pair lists of an evaluation, from the cells or from the candidates of the last sort.
  real neighbour_skin() const { return config_.neighbour_skin * config_.smoothing_length; }
  bool neighbour_lists_due() const;
  void update_pair_lists(real support);
  void scan_cells_for_pairs(real radius, bool into_candidates);
  void keep_pairs_in_support(real support);
  void rescan_at_sort();
  void index_wall_blocks();  // cells.cpp
  void restore_neighbour_candidates();  // checkpoint.cpp
  // wall_tiles.cpp: lays the wall source's tiles the flow needs (all of them missing or `force`), drops those
  // it left, and sorts the boundary by cell.
  void refresh_wall_tiles(bool force);
  bool wall_tiles_missing(real reach) const;  // a tile within reach of some flow particle is not alive
  bool wall_tiles_known_alive(real need) const;  // by the last check, no tile within need can be missing
  void remember_wall_check(real reach);
  void lay_tile(int64_t tile);  // appends its particles to the boundary (unsorted)
  template <class F>
  void for_each_wall_array(F&& f);  // f(v) for every per-wall-particle array
  void keep_boundary(const std::vector<char>& keep);  // drops the boundary particles whose keep[b] is 0
  void restore_wall_tiles(const std::vector<int64_t>& live);  // exactly these tiles alive (ascending), sorted
  void sort_boundary();
  void set_fixed_wall_normals(const std::vector<Vec<D>>& given);
  // One force evaluation (forces.cpp) and its steps.
  void evaluate(bool compute_dt);
  void update_fluid_state();              // EOS, per-particle volumes and the neighbour pack
  void update_wall_volumes();             // m / rho and p / rho^2 of the active wall particles
  solver_detail::PassContext<D> pass_context();
  void apply_rheology();                  // rheology.cpp: mu_eff per material batch, capped
  void set_time_step(bool viscous);       // from the evaluation's maxima
  bool implicit_viscosity() const;        // a viscous scene with numerics.viscosity implicit
  void implicit_viscous_step(real dt);    // implicit_viscosity.cpp: backward Euler on the fluid velocities
  void shifting_gradients();              // shifting.cpp: grad C and the free-surface scale, at the pair lists
  void apply_shifting(real dt);           // shifting.cpp: the shift, added to the positions
  void check_state();
  real potential_energy() const;
  void create_inlet_buffers();
  void impose_inlet_state();     // buffer particles: the inlet's velocity, hydrostatic density
  void advance_inlets();         // buffer particles past their plane become flow; new ones enter behind
  real inlet_density(const InletSpec<D>& in, const Vec<D>& p) const;
  bool in_inlet_buffer(const Vec<D>& p) const;
};

extern template class Solver<2>;
extern template class Solver<3>;

}  // namespace runout
