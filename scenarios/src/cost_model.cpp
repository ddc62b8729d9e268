// The cost model (cost_model.hpp, docs/tradeoff.md).
#include "runout/scenarios/cost_model.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "runout/terrain/terrain.hpp"
#include "scene_count.hpp"
#include "screening_run.hpp"

namespace runout {

namespace {

// Volume an inlet delivers over [0, T]: its speed (piecewise linear in t, speed_at) integrated exactly by
// trapezoids between the table's times, times the opening.
template <int D>
double inlet_volume(const InletSpec<D>& in, double dp, double T) {
  const double area = in.opening_area(dp);
  std::vector<double> t = {0.0, T};
  for (const auto& row : in.speed)
    if (row[0] > 0 && row[0] < T) t.push_back(row[0]);
  std::sort(t.begin(), t.end());
  double v = 0;
  for (size_t i = 1; i < t.size(); ++i) v += 0.5 * (in.speed_at(t[i - 1]) + in.speed_at(t[i])) * (t[i] - t[i - 1]);
  return v * area;
}

// What the implicit viscous step's two CG solves a step cost, in a_D-weighted passes over the pairs: the measured
// extra time a step, implicit against explicit, over a_D fluid_mean (h/dp)^D, one thread, side by side on the
// quiet machine 2026-12-05 (docs/tradeoff.md, "The cost model"), at the a_D of calibrated() (fitted together, to
// a fixed point). 2D: the Bui column (10.1 CG iterations a solve); 3D: the flume's C6 and the catchment's G7 at
// draft (3.2 and 1.6 iterations: 1.41 and 1.10, geometric mean). The solve's work grows with its iterations, which
// the scene does not give before the run.
constexpr double kImplicitViscousPasses2D = 4.22, kImplicitViscousPasses3D = 1.25;

// A flow's plan extent in columns of dp^(D-1), up to a constant of its shape: fluid^((D-1)/D).
double flow_columns(const CostFeatures& f) {
  return std::pow(std::max(f.fluid, f.fluid_peak), (f.dimensions - 1.0) / f.dimensions);
}

// The screening rung's features (cost_model.hpp): its particles at screening.spacing, its kernel's
// neighbours, and the CFL step of the fastest flow the corridor's energy line allows.
CostFeatures screening_cost_features(const Scene& scene) {
  const nlohmann::json& j = *scene.document;
  const ScreeningSettings s = screening_settings(j, scene);
  const terrain::TerrainModel& tm = *scene.terrain;
  const auto& setup = std::get<SceneSetup<3>>(scene.setup);
  const ScreeningParticles start = screening_particles(j, tm, s.spacing);
  CostFeatures f;
  f.model = "screening";
  f.dimensions = scene.dimensions;
  f.duration = scene.duration;
  f.fluid = static_cast<double>(start.release);
  double inflow = 0;
  if (start.inflow_particle_volume > 0)
    for (const auto& in : setup.inlets) inflow += inlet_volume(in, scene.dp, scene.duration) / start.inflow_particle_volume;
  f.fluid_mean = f.fluid + 0.5 * inflow;
  f.fluid_peak = f.fluid + inflow;
  const double h = s.kernel_ratio() * s.spacing;
  f.neighbours = (h / s.spacing) * (h / s.spacing);
  f.passes = 1;
  const auto& g = setup.config.gravity;
  const double speed = std::sqrt(2.0 * std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * tm.max_energy_height);
  f.dt0 = speed > 0 ? std::min<double>(s.dt_max, s.cfl * h / speed) : s.dt_max;
  return f;
}

}  // namespace

CostFeatures cost_features(const Scene& scene) {
  if (is_screening(scene)) return screening_cost_features(scene);
  CostFeatures f;
  f.dimensions = scene.dimensions;
  f.duration = scene.duration;
  std::visit(
      [&](const auto& setup) {
        constexpr int D = std::decay_t<decltype(setup)>::kDim;
        const SolverConfig& c = setup.config;
        const double h = c.smoothing_length, dp = c.dp;
        f.fluid = static_cast<double>(scene.counts.fluid);  // made or only counted (estimate_scene)
        f.boundary_fixed = static_cast<double>(scene.counts.walls);
        f.bed = static_cast<double>(scene.counts.bed);
        f.boundary = f.boundary_fixed + f.bed;
        f.neighbours = std::pow(h / dp, D);
        // Inlets: their buffers work from the start; what they deliver joins the flow linearly on average.
        double buffer = 0, inflow = 0;
        for (const auto& in : setup.inlets) {
          buffer += in.opening_area(dp) / std::pow(dp, D - 1) * inlet_buffer_layers(c);
          inflow += inlet_volume(in, dp, scene.duration) / std::pow(dp, D);
        }
        f.fluid_mean = f.fluid + buffer + 0.5 * inflow;
        f.fluid_peak = f.fluid + buffer + inflow;

        // The engine's step limits at rest (solver.cpp): acoustic cfl h / c0, force cfl sqrt(h / g), viscous
        // 0.125 h^2 / nu with mu_eff capped (yield-stress and power-law materials reach the cap in their plugs).
        double rho_min = 1e300;
        for (const auto& m : setup.materials) rho_min = std::min<double>(rho_min, m.density);
        const double cap = c.max_viscosity > 0 ? c.max_viscosity
                                               : c.viscosity_cap_factor * 0.125 * h * rho_min * c.speed_of_sound / c.cfl;
        double g = 0;
        for (int d = 0; d < D; ++d) g += c.gravity[d] * c.gravity[d];
        g = std::sqrt(g);
        double dt = c.cfl * h / c.speed_of_sound;
        if (g > 0) dt = std::min(dt, c.cfl * std::sqrt(h / g));
        // The implicit viscous step has no viscous limit; its two solves a step cost pair passes of their own.
        const bool implicit = c.viscous_step == ViscousStep::implicit;
        f.passes = 1;
        for (const auto& m : setup.materials) {
          const auto rheology = make_rheology(m);
          if (rheology->is_inviscid()) continue;
          f.passes = 2 + (implicit ? (D == 2 ? kImplicitViscousPasses2D : kImplicitViscousPasses3D) : 0.0);
          const double mu = std::min<double>(rheology->viscosity_bound(), cap);
          if (!implicit) dt = std::min(dt, 0.125 * h * h * m.density / mu);
        }
        f.dt0 = dt;
      },
      scene.setup);
  return f;
}

SceneEstimate estimate_scene(const SceneSpec& spec) {
  const Scene scene = count_scene(spec);
  SceneEstimate e;
  e.dimensions = scene.dimensions;
  e.dp = scene.dp;
  e.max_particles = scene.max_particles;
  e.cost = cost_features(scene);
  e.counts = scene.counts;
  return e;
}

CostModel CostModel::calibrated() {
  CostModel m;
  // Fitted as `runout calibrate` fits, on 15 runs of the shipped scenes, one thread each, two at once on the 2-core
  // development machine, 2026-12-05 evening, default (native) build, the implicit viscous step the default of the
  // yield-stress scenes, with the bed alive near the flow measured (particles.boundary_peak), a_D and the implicit
  // passes above iterated to agree: docs/tradeoff.md, "The cost model": the runs, the commands, the errors.
  m.two_d = {1.016, 1.237e-7, 3.24e-8, 7.80e-5};
  m.three_d = {0.974, 2.443e-7, 4.53e-8, 2.256e-4};
  m.bed_per_flow_column = 114;
  // The screening rung's, fitted by `runout calibrate` on 10 completed one-thread screening runs, one at a time on
  // the idle 2-core machine, 2026-12-07, after its neighbour search went by rows of cells: the flume's C0 at three
  // kernels, the Jacksboro block and hydrograph, Alr at 14 and 20 deg (scripts/screening_cost_runs.sh;
  // docs/tradeoff.md, "The screening rung's cost").
  m.screening = {0.3985, 7.209e-8, 0.0, 5.091e-4, 1.315e-7};
  // Not fitted by `runout calibrate` (its runs are one-thread): least squares on the relative time error of
  // twelve one- against two-thread pairs, 2026-11-29 (docs/tradeoff.md, "Two threads"): the flume (C0 at
  // 0.07 / 0.05 / 0.03 m), the catchment's G7 at 6 and 4 m, the Jacksboro slope at 1 m, the 2D dam break and
  // column collapse, the 3D dam break scene, best of three two-thread runs each (two-thread wall times on the
  // 2-vCPU machine scatter by up to 2x run to run), and the 3D dam break benchmark at three sizes. Terrain
  // flows of a few hundred particles gain 1.5-1.8x (their wall contact is much of the work), so the speed-up
  // saturates early: N_half = 70 (480 before, fitted to four noisier pairs).
  m.parallel_efficiency = 0.8;
  m.parallel_half_fluid = 70;
  return m;
}

const CostCoefficients& CostModel::coefficients(const CostFeatures& f) const {
  if (f.model == "screening") return screening;
  return f.dimensions == 2 ? two_d : three_d;
}

double CostModel::boundary_peak(const CostFeatures& f) const {
  return f.boundary_fixed + std::min(f.bed, bed_per_flow_column * flow_columns(f));
}

double CostModel::speedup(const CostFeatures& f, int threads) const {
  const double n = std::max(0.0, f.fluid_mean);
  const double e = n > 0 ? parallel_efficiency * n / (n + parallel_half_fluid) : 0.0;
  return 1.0 + e * std::max(0, threads - 1);
}

CostPrediction CostModel::predict(const CostFeatures& f, int threads) const {
  const CostCoefficients& k = coefficients(f);
  CostPrediction p;
  p.particles = f.fluid + f.boundary;
  p.fluid_peak = std::max(f.fluid, f.fluid_peak);
  p.boundary_peak = boundary_peak(f);
  p.steps = f.dt0 > 0 ? std::ceil(k.step_ratio * f.duration / f.dt0) : 0;
  p.speedup = speedup(f, threads);
  p.seconds_per_step =
      (k.a_fluid * f.fluid_mean * f.neighbours * f.passes + k.b_fluid * f.fluid_mean + k.b_boundary * p.boundary_peak +
       k.c_step) /
      p.speedup;
  p.seconds = p.steps * p.seconds_per_step;
  return p;
}

// k_bed: the geometric mean of the measured bed peak over the flow's columns (least squares on log ratio).
double fit_bed_per_flow_column(const std::vector<CostObservation>& runs, double prior) {
  double log_sum = 0;
  int n = 0;
  for (const auto& r : runs) {
    const double bed_peak = r.boundary_peak - r.features.boundary_fixed;
    if (r.features.bed <= 0 || flow_columns(r.features) <= 0 || bed_peak <= 0) continue;
    log_sum += std::log(bed_peak / flow_columns(r.features));
    ++n;
  }
  return n > 0 ? std::exp(log_sum / n) : prior;
}

// The coefficients of one group of runs (a model in a dimension). Steps: the geometric mean of measured /
// (duration / dt0), i.e. least squares on log ratio. Time per step on one thread, y = wall * speedup / steps,
// linear in three columns (SPH: the pair term, the walls alive, 1; screening: the pair term, the flow
// particles, 1); rows divided by y so the fit minimises relative error (a small scene counts as much as a large
// one). A negative coefficient is dropped and the rest refitted.
void fit_group(const std::vector<const CostObservation*>& obs, const CostModel& out, bool screening, CostCoefficients& k) {
  double log_sum = 0;
  for (const auto* r : obs) log_sum += std::log(r->steps * r->features.dt0 / r->features.duration);
  k.step_ratio = std::exp(log_sum / obs.size());
  std::vector<int> cols = {0, 1, 2};
  for (;;) {
    Eigen::MatrixXd A(obs.size(), cols.size());
    Eigen::VectorXd b = Eigen::VectorXd::Ones(obs.size());
    for (size_t i = 0; i < obs.size(); ++i) {
      const auto& r = *obs[i];
      const double y = r.wall_seconds * out.speedup(r.features, r.threads) / r.steps;
      const double walls = r.boundary_peak > 0 ? r.boundary_peak : out.boundary_peak(r.features);
      const double x[3] = {r.features.fluid_mean * r.features.neighbours * r.features.passes,
                           screening ? r.features.fluid_mean : walls, 1.0};
      for (size_t c = 0; c < cols.size(); ++c) A(i, c) = x[cols[c]] / y;
    }
    const Eigen::VectorXd coef = A.colPivHouseholderQr().solve(b);
    int worst = -1;
    for (size_t c = 0; c < cols.size(); ++c)
      if (coef[c] < 0 && (worst < 0 || coef[c] < coef[worst])) worst = static_cast<int>(c);
    if (worst >= 0 && cols.size() > 1) {
      cols.erase(cols.begin() + worst);
      continue;
    }
    double a[3] = {0, 0, 0};
    for (size_t c = 0; c < cols.size(); ++c) a[cols[c]] = std::max(0.0, coef[c]);
    k.a_fluid = a[0];
    (screening ? k.b_fluid : k.b_boundary) = a[1];
    k.c_step = a[2];
    return;
  }
}

CostModel fit_cost_model(const std::vector<CostObservation>& runs, const CostModel& prior) {
  CostModel out = prior;
  std::vector<CostObservation> sph;
  for (const auto& r : runs)
    if (r.features.model != "screening") sph.push_back(r);
  out.bed_per_flow_column = fit_bed_per_flow_column(sph, prior.bed_per_flow_column);
  for (int group : {2, 3, 0}) {  // SPH in 2D, in 3D; 0: the screening rung
    std::vector<const CostObservation*> obs;
    for (const auto& r : runs) {
      const bool screening = r.features.model == "screening";
      if ((group == 0) != screening || (!screening && r.features.dimensions != group)) continue;
      if (r.steps > 0 && r.wall_seconds > 0 && r.features.dt0 > 0) obs.push_back(&r);
    }
    if (obs.size() < 2) continue;
    fit_group(obs, out, group == 0, group == 0 ? out.screening : group == 2 ? out.two_d : out.three_d);
  }
  return out;
}

nlohmann::json cost_features_json(const CostFeatures& f) {
  return {{"model", f.model},
          {"fluid", f.fluid},
          {"fluid_mean", f.fluid_mean},
          {"fluid_peak", f.fluid_peak},
          {"boundary", f.boundary},
          {"boundary_fixed", f.boundary_fixed},
          {"bed", f.bed},
          {"neighbours", f.neighbours},
          {"passes", f.passes},
          {"duration_s", f.duration},
          {"dt0_s", f.dt0}};
}

bool cost_observation_from_metrics(const std::string& metrics_json, CostObservation& out) {
  const auto j = nlohmann::json::parse(metrics_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("cost_features") || !j["cost_features"].is_object())
    return false;
  const auto& c = j["cost_features"];
  try {
    out.features.model = c.value("model", std::string("sph3d"));  // stored before the screening rung's: SPH
    out.features.dimensions = j.at("dimensions").get<int>();
    out.features.fluid = c.at("fluid").get<double>();
    out.features.fluid_mean = c.at("fluid_mean").get<double>();
    out.features.boundary = c.at("boundary").get<double>();
    // Stored before the bed was laid near the flow: every boundary particle was alive.
    out.features.boundary_fixed = c.value("boundary_fixed", out.features.boundary);
    out.features.bed = c.value("bed", 0.0);
    out.features.fluid_peak = c.value("fluid_peak", out.features.fluid);
    out.boundary_peak = j.contains("particles") ? j["particles"].value("boundary_peak", 0.0) : 0.0;
    out.features.neighbours = c.at("neighbours").get<double>();
    out.features.passes = c.at("passes").get<double>();
    out.features.duration = c.at("duration_s").get<double>();
    out.features.dt0 = c.at("dt0_s").get<double>();
    out.steps = j.at("steps").get<double>();
    out.wall_seconds = j.at("wall_time_s").get<double>();
    out.threads = j.at("threads").get<int>();
    out.label = j.value("scene", std::string());
  } catch (const nlohmann::json::exception&) {
    return false;
  }
  // A stopped or failed run ran only part of its duration; a run whose team changed (it shared the cores
  // with other runs for part of it) is no sample of one thread count's speed.
  return j.value("status", std::string()) == "completed" && !j.contains("threads_least");
}

}  // namespace runout
