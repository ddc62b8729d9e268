#pragma once
// The cost model: a run's particle count and wall time predicted from the built scene before it runs
// (docs/tradeoff.md, "The cost model"). The work of an SPH step is the particle pairs it visits, so
//
//   steps          = k_D * duration / dt0
//   dt0            = min(cfl h / c0, 0.125 h^2 / nu_max, cfl sqrt(h / g))        (the engine's limits at rest;
//                                                                                   no viscous one when implicit)
//   seconds/step   = (a_D * fluid_mean * (h/dp)^D * passes + b_D * boundary + c_D) / speedup
//   speedup        = 1 + e * fluid_mean / (fluid_mean + N_half) * (threads - 1)
//
// fluid_mean is the flow particles averaged over the run (inlets add theirs as they enter), (h/dp)^D scales
// the neighbours each one visits, passes is 2 when a material carries a stress (velocity gradient, then
// stress divergence) and 1 for inviscid water, plus what the implicit viscous step's two solves a step cost in
// such passes (measured, cost_model.cpp); boundary is the boundary particles alive at most: the fixed
// walls, and on terrain the bed near the flow, predicted as
//
//   bed alive      = min(bed, k_bed * fluid_peak^((D-1)/D))
//
// the bed is laid a few layers deep under and around the wetted area, and a flow whose shape does not change
// with dp wets a plan area of fluid_peak^((D-1)/D) columns of dp^(D-1) times a constant of its spreading
// (halve dp: 8 times the particles, 4 times the columns). k_bed is fitted to the runs'
// particles.boundary_peak (their cell sorting is per step; only those next to the flow do pair work, which
// the fluid term carries). k_D takes up what
// the rest state does not see (flow speed in the acoustic limit, the force limit of impacts). A run of a few
// dozen particles gains little from a second thread (its step is mostly fork-join overhead), hence the
// speed-up saturating in the fluid count; terrain flows of a hundred or more already gain 1.5x (their wall
// contact is much of the work). The coefficients are fitted by least squares on relative error
// from stored one-thread runs (`runout calibrate`); e and N_half come from one- against two-thread runs.
//
// The screening rung (a scene's "model": "screening", thickness-integrated SPH: docs/design.md) has coefficients
// of its own, on features of its own: fluid is its particles at screening.spacing (the release's lattice; a
// hydrograph's arrive over the run, counted in fluid_mean and fluid_peak as an inlet's), neighbours
// (h_k0 / spacing)^2, one pass, no wall particles (its bed is a grid), and
//
//   dt0            = cfl h_k0 / sqrt(2 g E)
//
// with E the corridor's energy-line height above the ground at most (terrain max_energy_height): the step of
// the fastest flow the corridor allows, whose steps the run's CFL limit takes. Its time per step has a term per
// flow particle besides the pair term (b_fluid: the bed lookup, friction and curvature each particle does),
// which the 3D rungs' fit leaves at 0.
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "runout/scenarios/scene.hpp"

namespace runout {

struct CostFeatures {
  std::string model = "sph3d";  // the scene's flow model ("model": sph3d, or screening)
  int dimensions = 3;
  double fluid = 0;        // flow particles at the start
  double fluid_mean = 0;   // averaged over the run (with inlets' inflow)
  double fluid_peak = 0;   // at most at once: with all an inlet delivers
  double boundary = 0;     // every boundary particle the scene describes: boundary_fixed + bed
  double boundary_fixed = 0;  // always alive: walls, structures, a terrain laid whole
  double bed = 0;          // a terrain's bed laid only near the flow (the engine's wall source): all it can lay
  double neighbours = 0;   // (h/dp)^D
  double passes = 1;       // 1 inviscid, 2 with a stress term, more with the implicit viscous step
  double duration = 0;     // [s]
  double dt0 = 0;          // the step at rest [s]
};
CostFeatures cost_features(const Scene& scene);

// A read scene priced without making its particles: build_scene's terrain, checks and refusals (every one a
// build would give, the particle limit included), with the 3D particles counted, not made (no particle arrays,
// no bed laid). What an estimate, a refusal and a sweep's check of its variants need; a run builds the scene.
struct SceneEstimate {
  int dimensions = 2;
  real dp = 0;
  long max_particles = 0;
  ParticleCounts counts;  // the 3D particles (none for a screening scene: its own are in cost.fluid_peak)
  CostFeatures cost;
};
SceneEstimate estimate_scene(const SceneSpec& spec);

struct CostCoefficients {
  double step_ratio = 1.2;  // k: steps / (duration / dt0)
  double a_fluid = 0;       // [s] per fluid particle x (h/dp)^D x pass, one thread
  double b_boundary = 0;    // [s] per boundary particle, one thread
  double c_step = 0;        // [s] per step
  double b_fluid = 0;       // [s] per flow particle (the screening rung; 0 for SPH, whose is in a_fluid's term)
};

struct CostPrediction {
  double particles = 0;   // fluid + boundary the scene describes
  double fluid_peak = 0;      // flow particles at most at once
  double boundary_peak = 0;   // boundary particles alive at most at once (fixed + bed near the flow)
  double steps = 0;
  double seconds_per_step = 0;
  double seconds = 0;     // wall-clock
  double speedup = 1;     // of `threads` over one
};

struct CostModel {
  CostCoefficients two_d, three_d;
  CostCoefficients screening;           // the screening rung's, on its own features (above)
  double parallel_efficiency = 0.9;     // e: of each thread after the first, for a large run
  double parallel_half_fluid = 380;     // N_half: the fluid count at which a thread gives half of e
  double bed_per_flow_column = 0;       // k_bed: bed particles alive at most per fluid_peak^((D-1)/D)
  double speedup(const CostFeatures& f, int threads) const;
  double boundary_peak(const CostFeatures& f) const;
  // The coefficients of the features' model: screening, or SPH in their dimension.
  const CostCoefficients& coefficients(const CostFeatures& f) const;
  // The coefficients fitted on this project's measurements (the figures and the command: docs/tradeoff.md).
  static CostModel calibrated();
  CostPrediction predict(const CostFeatures& f, int threads) const;
};

// One measured run, for the fit.
struct CostObservation {
  CostFeatures features;
  double steps = 0;
  double wall_seconds = 0;
  double boundary_peak = 0;  // measured (particles.boundary_peak); 0 when not stored
  int threads = 1;
  std::string label;
};

// Least squares on relative error, per dimension and for the screening rung (a group with fewer than two
// observations keeps `prior`'s coefficients); a negative coefficient is dropped and the rest refitted. The time per step is fitted on the
// measured boundary peak where a run has one; k_bed is the geometric mean of the measured bed peak over
// fluid_peak^((D-1)/D) on the runs with a bed (the prior's without one).
CostModel fit_cost_model(const std::vector<CostObservation>& runs, const CostModel& prior = CostModel::calibrated());

// The features as metrics.json stores them ("cost_features"), read back by cost_observation_from_metrics.
nlohmann::json cost_features_json(const CostFeatures& f);

// The features and measured cost of a stored run, from its metrics.json text ("cost_features", "steps",
// "wall_time_s", "threads"); false when the run lacks them (stored before the cost model existed).
bool cost_observation_from_metrics(const std::string& metrics_json, CostObservation& out);

}  // namespace runout
