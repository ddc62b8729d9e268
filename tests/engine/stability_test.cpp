// Stability at the extremes of the parameters, and two physical facts the rheology must reproduce.
//
// A. Matrix (TEST_P StabilityMatrix): small 2D scenes, a block of material released on an inclined plane, one
//    parameter varied at a time around a base case plus a few corner combinations. Every run goes through
//    run_scene (the product path) and must end "completed" (the solver throws on NaN/Inf, dt under the floor
//    or a leak, which run_scene reports as "failed"), with exact mass, no leak, finite series, and kinetic
//    energy never above the potential energy released plus what the fluid could give back from its initial
//    elastic (Tait) energy. See EnergyTolerance for why that is the bound.
//
// B. Physics (Solver driven, positions followed by particle id):
//    - friction-HBP on an infinite slope (tilted gravity, periodic along the slope): stays put when
//      sin(phi) > tan(slope), slides when sin(phi) < tan(slope) (NOTE: with tau_y = P sin(phi) the threshold
//      is sin(phi) = tan(slope), not phi = slope: on a slope of 25 deg a friction angle of 27.8 deg is
//      the limit);
//    - a Bingham column with tau_y = 1e5 Pa stands rigid.
//    Both run at the product's defaults since the implicit viscous step (2026-12-05): the tables at each test
//    below are the history of the explicit step's cap that they needed before. With the explicit step both
//    resting checks depend on the effective-viscosity cap (numerics.viscosity_cap_factor): a cap far
//    below tau_y m lets resting material creep like a viscous fluid at about rho g H^2 / (k mu_cap). The factor
//    used below was chosen from measurements (see the comments at each test) and is set explicitly in the
//    scene: these tests check the physics at a stated numerical setting, not the product default.
//
// Tests named DISABLED_ assert facts the current engine gets wrong (reasons at each); run them with
// --gtest_also_run_disabled_tests. All scenes run on one thread: they are a few hundred particles.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <omp.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "runout/engine/solver.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr double kG = 9.81;
constexpr double kDeg = kPi / 180.0;

// ---------------------------------------------------------------------------------------------------------
// Energy bound (EnergyTolerance).
//
// With dissipative stresses only, KE(t) + PE(t) + E_el(t) <= KE(0) + PE(0) + E_el(0), where E_el is the
// elastic energy of the weakly compressible fluid (and of the DBC wall particles, which start at rest density
// and only store what they take). KE(0) = 0 and E_el(t) >= 0, so KE(t) - PE_released(t) <= E_el(0).
// E_el(0) is not zero because particles start at hydrostatic density; it is about M g H / 600 with the default
// c0 = 10 sqrt(g H), i.e. 0.2 % of the potential energy of the block. On top of it we allow 1 % of the energy
// released, for the time-integration error of the symplectic scheme and for the density-diffusion term,
// which is not strictly energy-conserving. Anything above is energy made by the numerics.
// Specific internal energy of the Tait EOS: u(rho) = int_rho0^rho P(s)/s^2 ds
//   = (B/rho0) [ (x^(gamma-1) - 1)/(gamma-1) + 1/x - 1 ],  x = rho/rho0,  B = c0^2 rho0 / gamma  (u >= 0).
template <int D>
double elastic_energy(const SceneSetup<D>& s) {
  const auto& c = s.config;
  double e = 0;
  for (size_t i = 0; i < s.fluid.size(); ++i) {
    const double r0 = s.materials[s.fluid.material[i]].density;
    const double x = s.fluid.rho[i] / r0, gam = c.eos_gamma;
    const double B = c.speed_of_sound * c.speed_of_sound * r0 / gam;
    e += s.fluid.mass[i] * (B / r0) * ((std::pow(x, gam - 1.0) - 1.0) / (gam - 1.0) + 1.0 / x - 1.0);
  }
  return e;
}

double energy_tolerance(double elastic0, double released) { return elastic0 + 0.01 * std::max(released, 0.0); }

// ---------------------------------------------------------------------------------------------------------
// Scene builders (JSON, parsed by the product's parser).

struct Material {
  std::string rheology = "hbp";
  double density = 2000, viscosity = 1.0, flow_index = 1.0, regularisation = 100.0;
  double yield_stress = 100.0, friction_angle = 0.0, cohesion = 0.0;
  json to_json() const {
    json m = {{"name", "debris"}, {"rheology", rheology}, {"density", density}, {"viscosity", viscosity}};
    if (rheology != "newtonian" && rheology != "bingham") {
      m["flow_index"] = flow_index;
      m["regularisation"] = regularisation;
    }
    if (rheology == "bingham" || rheology == "hbp") m["yield_stress"] = yield_stress;
    if (rheology == "friction-hbp") {
      m["friction_angle"] = friction_angle;
      m["cohesion"] = cohesion;
    }
    return m;
  }
};

// A block (length x height, in its own slope-aligned frame) resting on a plane inclined at `slope` degrees,
// the plane long enough that the block stays on it for the whole run.
struct BlockOnPlane {
  std::string name = "block";
  Material material;
  double slope = 30.0, dp = 0.01, duration = 0.3, length = 0.2, height = 0.1;
  double cap_factor = 0;  // 0: product default
  json to_json() const {
    const double a = slope * kDeg;
    // Travel budget: a free slide without resistance plus the front of an inviscid dam break, 2 sqrt(g H) t
    // (Ritter), plus margin. A particle running off the end of the plane falls out of the domain, a leak.
    const double travel =
        0.5 * kG * std::sin(a) * duration * duration + 2.0 * std::sqrt(kG * height) * duration + 0.1;
    const double upstream = slope < 5.0 ? travel : 0.1;  // a flat bed: the block spreads both ways
    const double plane_length = upstream + length + travel;
    json numerics = json::object();
    if (cap_factor > 0) {  // the explicit step's cap (the default for yield-stress materials is the implicit step)
      numerics["viscosity"] = "explicit";
      numerics["viscosity_cap_factor"] = cap_factor;
    }
    return {{"name", name},
            {"dimensions", 2},
            {"dp", dp},
            {"duration", duration},
            {"materials", {material.to_json()}},
            {"numerics", numerics},
            {"fluid", {{{"origin", {upstream * std::cos(a), -upstream * std::sin(a)}},
                        {"size", {length, height}},
                        {"angle", slope},
                        {"material", "debris"}}}},
            {"boundaries", {{{"type", "plane"}, {"origin", {0.0, 0.0}}, {"length", plane_length}, {"angle", slope}}}},
            {"output", {{"series_interval", 0.01}}}};
  }
};

// ---------------------------------------------------------------------------------------------------------
// Running a scene through run_scene and reading its outputs.

struct RunResult {
  json metrics;
  std::vector<std::map<std::string, double>> series;  // rows of series/run.csv
  double elastic0 = 0;
  double wall_seconds = 0;
};

std::vector<std::map<std::string, double>> read_csv(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, double>> rows;
  if (!std::getline(in, line)) return rows;
  {
    std::stringstream ss(line);
    std::string h;
    while (std::getline(ss, h, ',')) header.push_back(h);
  }
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    std::map<std::string, double> row;
    for (size_t k = 0; k < header.size() && std::getline(ss, cell, ','); ++k) row[header[k]] = std::stod(cell);
    rows.push_back(row);
  }
  return rows;
}

fs::path scratch_dir(const std::string& name) {
  return fs::temp_directory_path() / ("runout_stability_" + std::to_string(::getpid()) + "_" + name);
}

RunResult run(const std::string& scene_json, const std::string& name) {
  const Scene scene = parse_scene(scene_json);
  RunResult r;
  r.elastic0 = std::visit([](const auto& s) { return elastic_energy(s); }, scene.setup);
  RunOptions opt;
  opt.out_dir = scratch_dir(name);
  opt.threads = 1;  // a few hundred particles: one thread is faster and immune to oversubscribed cores
  fs::remove_all(opt.out_dir);
  const auto t0 = std::chrono::steady_clock::now();
  const RunSummary sum = run_scene(scene, opt);
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.metrics = json::parse(sum.metrics_json);
  r.series = read_csv(opt.out_dir / "series" / "run.csv");
  fs::remove_all(opt.out_dir);
  return r;
}

// The checks every run must pass.
void expect_stable(const RunResult& r, double duration) {
  const json& m = r.metrics;
  ASSERT_EQ(m.at("status"), "completed") << m.value("error", std::string());
  EXPECT_GE(m.at("simulated_time_s").get<double>(), duration * (1 - 1e-9));
  // Exact mass: nothing may leave a closed scene and every particle keeps its mass.
  EXPECT_LT(std::abs(m.at("mass").at("relative_error").get<double>()), 1e-12);
  EXPECT_EQ(m.at("particles").at("fluid_final"), m.at("particles").at("fluid_initial"));
  EXPECT_EQ(m.at("leaks"), 0);
  EXPECT_GT(m.at("dt").at("min_s").get<double>(), 0.0);
  EXPECT_TRUE(std::isfinite(m.at("max_mach").get<double>()));
  // Energy, sample by sample, and the run's own summary of it.
  ASSERT_GE(r.series.size(), 10u);
  double max_released = 0, worst = -1e300;
  const std::map<std::string, double>* worst_row = nullptr;
  for (const auto& row : r.series) {
    for (const auto& [k, v] : row) ASSERT_TRUE(std::isfinite(v)) << k << " at t = " << row.at("t");
    const double ke = row.at("kinetic_energy"), rel = row.at("potential_energy_released");
    max_released = std::max(max_released, rel);
    const double margin = ke - rel - energy_tolerance(r.elastic0, rel);
    if (margin > worst) {
      worst = margin;
      worst_row = &row;
    }
  }
  EXPECT_LE(worst, 0.0) << "at t = " << worst_row->at("t") << " s: KE " << worst_row->at("kinetic_energy")
                        << " J, PE released " << worst_row->at("potential_energy_released")
                        << " J, initial elastic energy " << r.elastic0 << " J";
  const double excess = m.at("energy").at("max_kinetic_minus_released_j").get<double>();
  EXPECT_TRUE(std::isfinite(excess));
  EXPECT_LE(excess, energy_tolerance(r.elastic0, max_released)) << "initial elastic energy " << r.elastic0 << " J";
}

// ---------------------------------------------------------------------------------------------------------
// A. The matrix.

struct MatrixCase {
  std::string name;
  BlockOnPlane scene;
};

BlockOnPlane base() { return BlockOnPlane{}; }

std::vector<MatrixCase> matrix_cases() {
  std::vector<MatrixCase> cases;
  auto add = [&](const std::string& name, auto&& edit) {
    BlockOnPlane s = base();
    edit(s);
    s.name = name;
    cases.push_back({name, s});
  };
  add("Base", [](BlockOnPlane&) {});
  // Yield stress tau_y (hbp), 0 .. 1e5 Pa, and Bingham at the top of the range.
  add("YieldStress0", [](BlockOnPlane& s) { s.material.yield_stress = 0; });
  add("YieldStress1e3", [](BlockOnPlane& s) { s.material.yield_stress = 1e3; });
  add("YieldStress1e5", [](BlockOnPlane& s) { s.material.yield_stress = 1e5; });
  add("Bingham1e5", [](BlockOnPlane& s) {
    s.material.rheology = "bingham";
    s.material.yield_stress = 1e5;
  });
  // Flow index n, 0.2 .. 2.
  add("FlowIndex0p2", [](BlockOnPlane& s) { s.material.flow_index = 0.2; });
  add("FlowIndex2", [](BlockOnPlane& s) { s.material.flow_index = 2.0; });
  // Regularisation m, 1 .. 1e4 s.
  add("Regularisation1", [](BlockOnPlane& s) { s.material.regularisation = 1; });
  add("Regularisation1e4", [](BlockOnPlane& s) { s.material.regularisation = 1e4; });
  // Consistency mu, 1e-3 .. 1e4 Pa s^n.
  add("Viscosity1em3", [](BlockOnPlane& s) { s.material.viscosity = 1e-3; });
  add("Viscosity1e4", [](BlockOnPlane& s) { s.material.viscosity = 1e4; });
  // Friction angle phi (friction-hbp, c = 0), 0 .. 50 deg.
  for (double phi : {0.0, 25.0, 50.0}) {
    add("FrictionAngle" + std::to_string(static_cast<int>(phi)), [phi](BlockOnPlane& s) {
      s.material.rheology = "friction-hbp";
      s.material.friction_angle = phi;
    });
  }
  // Slope, 0 .. 70 deg.
  for (double slope : {0.0, 10.0, 45.0, 70.0}) {
    add("Slope" + std::to_string(static_cast<int>(slope)), [slope](BlockOnPlane& s) { s.slope = slope; });
  }
  // Coarse and fine spacing.
  add("CoarseDp", [](BlockOnPlane& s) { s.dp = 0.02; });
  add("FineDp", [](BlockOnPlane& s) { s.dp = 0.005; });
  // Corners.
  add("CornerStiffShearThinning", [](BlockOnPlane& s) {  // n 0.2, m 1e4, tau_y 1e5, steep
    s.material.flow_index = 0.2;
    s.material.regularisation = 1e4;
    s.material.yield_stress = 1e5;
    s.slope = 70;
  });
  add("CornerNearlyInviscidSteepFine", [](BlockOnPlane& s) {  // fast flow: mu 1e-3, tau_y 0, 70 deg, fine dp
    s.material.viscosity = 1e-3;
    s.material.yield_stress = 0;
    s.material.flow_index = 2.0;
    s.slope = 70;
    s.dp = 0.005;
  });
  add("CornerViscousThickeningFlat", [](BlockOnPlane& s) {  // mu 1e4, n 2, m 1, flat, coarse
    s.material.viscosity = 1e4;
    s.material.flow_index = 2.0;
    s.material.regularisation = 1;
    s.slope = 0;
    s.dp = 0.02;
  });
  add("CornerFrictionSteep", [](BlockOnPlane& s) {  // phi 50 on 70 deg: slides, friction large
    s.material.rheology = "friction-hbp";
    s.material.friction_angle = 50;
    s.material.cohesion = 1e3;
    s.material.flow_index = 0.2;
    s.slope = 70;
  });
  add("CornerFrictionlessFlatFine", [](BlockOnPlane& s) {  // phi 0, c 0, mu 1e-3: a dam break on a flat bed
    s.material.rheology = "friction-hbp";
    s.material.friction_angle = 0;
    s.material.viscosity = 1e-3;
    s.slope = 0;
    s.dp = 0.005;
  });
  return cases;
}

// Cases that fail with the current engine for a known reason, kept asserting the same facts (run them with
// --gtest_also_run_disabled_tests). A raised viscosity cap with a large yield stress: the viscous wall term
// creates energy (KE exceeds the energy released by 0.24 J against 0.01 J of initial elastic energy), see
// ViscousWallTerm.DISABLED_CreatesNoEnergyAtHighViscosityCap for the cause and the fix.
std::vector<MatrixCase> pending_cases() {
  BlockOnPlane s = base();
  s.name = "CornerCapFactor10";
  s.material.yield_stress = 1e4;
  s.cap_factor = 10;
  s.duration = 0.2;
  return {{s.name, s}};
}

void PrintTo(const MatrixCase& c, std::ostream* os) { *os << c.name; }

class StabilityMatrix : public ::testing::TestWithParam<MatrixCase> {};

TEST_P(StabilityMatrix, EndsFiniteWithExactMassNoLeakAndNoEnergyCreated) {
  const MatrixCase& c = GetParam();
  const std::string scene = c.scene.to_json().dump();
  const RunResult r = run(scene, c.name);
  expect_stable(r, c.scene.duration);
  RecordProperty("wall_seconds", std::to_string(r.wall_seconds));
  std::cout << "[ info     ] " << c.name << ": " << r.metrics.at("particles").at("fluid_initial") << " particles, "
            << r.metrics.at("steps") << " steps, " << r.wall_seconds << " s wall, KE-released max "
            << r.metrics.at("energy").at("max_kinetic_minus_released_j") << " J (elastic " << r.elastic0
            << " J), Mach " << r.metrics.at("max_mach") << "\n";
}

INSTANTIATE_TEST_SUITE_P(Extremes, StabilityMatrix, ::testing::ValuesIn(matrix_cases()),
                         [](const ::testing::TestParamInfo<MatrixCase>& info) { return info.param.name; });
INSTANTIATE_TEST_SUITE_P(WallTermCases, StabilityMatrix, ::testing::ValuesIn(pending_cases()),
                         [](const ::testing::TestParamInfo<MatrixCase>& info) { return info.param.name; });

// ---------------------------------------------------------------------------------------------------------
// B. Physics, with the solver stepped directly so that every particle can be followed by id.

// Follows every fluid particle by id; unwraps a periodic x axis of length `period` (0: none).
class Tracker {
 public:
  Tracker(const ParticleArrays<2>& f, double period) : period_(period) {
    size_t n = 0;
    for (auto id : f.id) n = std::max<size_t>(n, id + 1);
    p0_.resize(n);
    last_.resize(n);
    now_.resize(n);
    for (size_t i = 0; i < f.size(); ++i) p0_[f.id[i]] = last_[f.id[i]] = now_[f.id[i]] = f.position(i);
  }
  void update(const ParticleArrays<2>& f) {
    for (size_t i = 0; i < f.size(); ++i) {
      const auto id = f.id[i];
      Vec<2> step = f.position(i) - last_[id];
      if (period_ > 0) step[0] -= period_ * std::round(step[0] / period_);
      now_[id] += step;
      last_[id] = f.position(i);
    }
  }
  double displacement(size_t id) const { return (now_[id] - p0_[id]).norm(); }
  double max_displacement() const {
    double m = 0;
    for (size_t id = 0; id < p0_.size(); ++id) m = std::max(m, displacement(id));
    return m;
  }
  double mean_x_displacement() const {
    double s = 0;
    for (size_t id = 0; id < p0_.size(); ++id) s += now_[id][0] - p0_[id][0];
    return s / p0_.size();
  }
  // Potential energy released, from unwrapped positions (a periodic wrap is not a fall).
  double released(const ParticleArrays<2>& f, const std::array<double, 3>& g) const {
    double e = 0;
    for (size_t i = 0; i < f.size(); ++i) {
      const Vec<2> d = now_[f.id[i]] - p0_[f.id[i]];
      e += f.mass[i] * (g[0] * d[0] + g[1] * d[1]);
    }
    return e;
  }
  const Vec<2>& initial(size_t id) const { return p0_[id]; }
  size_t size() const { return p0_.size(); }

 private:
  double period_;
  std::vector<Vec<2>> p0_, last_, now_;
};

struct DirectRun {
  double max_displacement = 0;     // over all particles and all steps [m]
  double mean_x_displacement = 0;  // at the end [m]
  double max_top_displacement = 0; // over particles of the initial top row [m]
  double max_energy_excess = -1e300, elastic0 = 0, max_released = 0;
  double mass_relative_error = 0;
  long steps = 0;
  double wall_seconds = 0;
  std::string error;
};

// Steps a 2D scene to its end, following particles. Throws nothing: a SimulationError lands in `error`.
DirectRun run_direct(const std::string& scene_json, double period = 0) {
  Scene scene = parse_scene(scene_json);
  auto& setup = std::get<SceneSetup<2>>(scene.setup);
  DirectRun r;
  r.elastic0 = elastic_energy(setup);
  double top = -1e300;
  for (size_t i = 0; i < setup.fluid.size(); ++i) top = std::max(top, setup.fluid.pos[1][i]);
  std::vector<size_t> top_row;
  for (size_t i = 0; i < setup.fluid.size(); ++i)
    if (setup.fluid.pos[1][i] > top - 0.25 * scene.dp) top_row.push_back(setup.fluid.id[i]);
  const auto gravity = setup.config.gravity;
  omp_set_num_threads(1);  // as in run(): small scenes
  Solver<2> solver(setup);
  Tracker tr(solver.fluid(), period);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    while (solver.time() < scene.duration) {
      solver.step();
      tr.update(solver.fluid());
      r.max_displacement = std::max(r.max_displacement, tr.max_displacement());
      for (size_t id : top_row) r.max_top_displacement = std::max(r.max_top_displacement, tr.displacement(id));
      const double rel = tr.released(solver.fluid(), gravity);
      r.max_released = std::max(r.max_released, rel);
      // KE - released - 1 % of released; must stay below the initial elastic energy (see EnergyTolerance).
      r.max_energy_excess =
          std::max(r.max_energy_excess, solver.energy().kinetic - rel - 0.01 * std::max(rel, 0.0));
    }
  } catch (const SimulationError& e) {
    r.error = e.what();
  }
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.steps = solver.steps();
  r.mean_x_displacement = tr.mean_x_displacement();
  const auto mb = solver.mass_balance();
  r.mass_relative_error =
      static_cast<double>((mb.total_current() + mb.total_outflow() - mb.total_initial()) / mb.total_initial());
  return r;
}

void expect_physical_run(const DirectRun& r) {
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_LT(std::abs(r.mass_relative_error), 1e-12);
  EXPECT_LE(r.max_energy_excess, r.elastic0) << "kinetic energy above the energy released (elastic " << r.elastic0
                                             << " J)";
}

// An infinite slope: a horizontal layer of thickness H, periodic along x, under gravity tilted by `slope`
// degrees, on a bed of three layers of wall particles. The layer has no end faces, so the stress state is the
// textbook one: shear tau = rho g z sin(slope), pressure P = rho g z cos(slope) at depth z, and the
// friction-HBP yield stress P sin(phi) holds it when sin(phi) > tan(slope), at every depth.
// (A finite cohesionless block on a plane is not a valid "stays put" test: its faces, perpendicular to the
// slope, are steeper than the friction angle and collapse, as they would in reality.)
std::string infinite_slope(double slope, double phi, double duration, double dp = 0.01,
                           double period = 0.15, double height = 0.1) {
  const double a = slope * kDeg;
  json s = {{"name", "infinite-slope"},
            {"dimensions", 2},
            {"dp", dp},
            {"duration", duration},
            {"gravity", {kG * std::sin(a), -kG * std::cos(a)}},
            {"materials",
             {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0},
               {"flow_index", 1.0}, {"regularisation", 100}, {"friction_angle", phi}, {"cohesion", 0}}}},
            {"fluid", {{{"min", {0.0, 0.0}}, {"max", {period, height}}, {"material", "debris"}}}},
            {"boundaries", {{{"type", "plane"}, {"origin", {0.0, 0.0}}, {"length", period}}}},
            {"domain", {{"min", {0.0, -0.1}}, {"max", {period, 1.0}}, {"periodic", {true, false}}}}};
  return s.dump();
}

constexpr double kSlope = 25.0;      // tan = 0.466
constexpr double kPhiRest = 45.0;    // sin = 0.707 > 0.466: rests
constexpr double kPhiSlide = 10.0;   // sin = 0.174 < 0.466: slides
// Measured on this infinite slope (dp = 0.01 m, H = 0.1 m, 150 particles, phi = 45 deg, slope 25 deg), largest
// displacement of any particle so far, in dp; steps and wall time (1 thread) for 0.5 s:
//   cap factor   t = 0.1 s   0.2 s   0.3 s   0.5 s     steps    wall
//        1         1.39      3.64    5.97    10.6       1.9k     1 s   creeps like a fluid of mu_cap = 208 Pa s
//       10         0.22      0.44    0.67    1.15      18k       9 s   (rho g sin H^2 T / (2 mu_cap) = 0.8 dp)
//      100         0.19      0.36    0.55    0.95     184k     130 s   no gain: what creeps now is not the cap
//                                                                      but alternate particle rows sliding past
//                                                                      each other (a zero-energy mode of the
//                                                                      nested SPH stress divergence)
// Factor 10 and 0.3 s: the resting layer moves under 0.7 dp while the same layer with phi = 10 deg slides
// ~12 dp (the rigid-slide value), at 10x the steps of the default cap. The 0.3 s window was chosen with those
// runs (it failed at 0.5 s). Since the implicit step (no cap) the resting layer is held to a spacing over the
// studies' own rest window, 2 s (output.rest_time of the catchment and flume scenes: what they count as at rest
// must stay put that long), chosen 2026-12-05 before the run; the law's own creep at m = 100 s (about 0.9 mm/s
// here, tests/engine/implicit_viscosity_test.cpp) moves it 0.2 dp in that time. The slide keeps 0.3 s.
constexpr double kRestDuration = 2.0;
constexpr double kSlideDuration = 0.3;

TEST(FrictionOnInfiniteSlope, StaysPutWhenSinPhiExceedsTanSlope) {
  ASSERT_GT(std::sin(kPhiRest * kDeg), std::tan(kSlope * kDeg));
  const double dp = 0.01, period = 0.15;
  const DirectRun r = run_direct(infinite_slope(kSlope, kPhiRest, kRestDuration, dp, period), period);
  expect_physical_run(r);
  EXPECT_LT(r.max_displacement, dp) << "largest displacement " << r.max_displacement / dp << " dp";
  std::cout << "[ info     ] rest: max displacement " << r.max_displacement / dp << " dp, mean downslope "
            << r.mean_x_displacement / dp << " dp, " << r.steps << " steps, " << r.wall_seconds << " s\n";
}

TEST(FrictionOnInfiniteSlope, SlidesWhenSinPhiBelowTanSlope) {
  ASSERT_LT(std::sin(kPhiSlide * kDeg), std::tan(kSlope * kDeg));
  const double dp = 0.01, period = 0.15, T = kSlideDuration;
  const DirectRun r = run_direct(infinite_slope(kSlope, kPhiSlide, T, dp, period), period);
  expect_physical_run(r);
  // A rigid layer sliding on its yielded base accelerates at g (sin(slope) - cos(slope) sin(phi)): 11.7 dp in
  // 0.3 s. The deforming layer with a viscous (mu = 1 Pa s) base cannot go faster; allow 20 % either way for
  // the wall treatment (DBC pressure and mirrored wall stress).
  const double a = kG * (std::sin(kSlope * kDeg) - std::cos(kSlope * kDeg) * std::sin(kPhiSlide * kDeg));
  const double rigid = 0.5 * a * T * T;
  EXPECT_GT(r.mean_x_displacement, 5 * dp);
  EXPECT_NEAR(r.mean_x_displacement, rigid, 0.2 * rigid);
  std::cout << "[ info     ] slide: mean downslope " << r.mean_x_displacement / dp << " dp (rigid slide "
            << rigid / dp << " dp), " << r.steps << " steps, " << r.wall_seconds << " s\n";
}

// The run's energy metrics on a periodic scene. Disabled: Solver::energy() takes the potential energy from
// wrapped positions, so a particle leaving at x = L and coming back at x = 0 counts as having climbed
// g_x L (here 0.2 kg x 4.1 m/s^2 x 0.15 m = 0.12 J per wrap) and metrics.json energy goes wrong for any scene
// with gravity along a periodic axis (an infinite slope, a body-force-driven channel). The fix is to add the
// wrap's -m g.(x_new - x_old) to the potential-energy offset when the solver wraps a particle.
TEST(EnergyMetric, PeriodicWrapIsNotAFall) {
  const RunResult r = run(infinite_slope(kSlope, kPhiSlide, kSlideDuration), "periodic-energy");
  expect_stable(r, kSlideDuration);
}

// A Bingham column 0.1 m wide, 0.2 m tall, tau_y = 1e5 Pa (50x the largest stress its weight makes, rho g H =
// 3.9 kPa) on a flat bed: it must stand. Measured (dp = 0.01 m, 200 particles), largest displacement so far
// of the top row / of any particle, in dp; steps and wall time (1 thread) for 0.5 s:
//   cap factor   t = 0.1 s    0.2 s      0.3 s      0.5 s       steps    wall
//        1       2.30/2.30  4.65/4.65  6.34/6.34  8.75/8.75     2.5k     1 s   slumps like a fluid of
//                                                                              mu_cap = 279 Pa s
//       10       0.31/0.73  0.66/2.82  0.89/2.88  1.57/4.29      25k    15 s
//      100       0.05/1.74  0.16/3.15  0.33/3.15  0.33/3.15     249k   113 s   KE - released reaches 3.3 J
//                                                                              (initial elastic 0.11 J)
// The "any particle" figures are particles at the foot of the column, set moving by the viscous wall term
// (see ViscousWallTerm below). With that term made consistent (wall velocity mirrored in the velocity
// gradient, as the force already mirrors the stress) the same runs give
//        1       2.27/2.27  4.60/4.60  6.28/6.28  8.64/8.64
//       10       0.34/0.34  0.67/0.67  0.99/0.99  1.60/1.60
//      100       0.02/0.03  0.06/0.06  0.10/0.10  0.17/0.17          (KE - released <= 0.01 J)
// Factor 10 and 0.2 s (about the free-fall time of the column): the top creeps 0.66 dp where the default cap
// lets it slump 4.6 dp. Factor 100 is what "rigid" needs over longer runs, at 10x the cost again.
// The tables above were measured with the former viscous operator (divergence of tau = 2 mu_eff D'). With the
// Morris et al. (1997) operator (docs/design.md) the capped column creeps 1.65x faster at the same cap: top
// displacement at 0.2 s 6.32 dp (factor 1, 1.0k steps), 1.11 dp (10, 9.9k), 0.76 dp (15, 14.9k), 0.58 dp (20,
// 19.8k); the former operator gave 0.67 dp at factor 10 (same driver). The Laplacian form approximates
// div(mu grad v) and so has no zero-traction free surface: a slumping column (vertical compression, horizontal
// extension) loses the extensional resistance the free surface gives the stress-divergence form. So this test
// now runs at factor 20 (2x the steps); the assertion (top < dp over 0.2 s) is unchanged.
std::string column(double duration, double dp = 0.01, double explicit_cap_factor = 0) {
  json s = {{"name", "rigid-column"},
            {"dimensions", 2},
            {"dp", dp},
            {"duration", duration},
            {"materials",
             {{{"name", "m"}, {"rheology", "bingham"}, {"density", 2000}, {"viscosity", 1.0}, {"yield_stress", 1e5}}}},
            {"fluid", {{{"min", {0.0, 0.0}}, {"max", {0.1, 0.2}}, {"material", "m"}}}},
            {"boundaries", {{{"type", "plane"}, {"origin", {-0.3, 0.0}}, {"length", 0.7}}}}};
  if (explicit_cap_factor > 0) s["numerics"] = {{"viscosity", "explicit"}, {"viscosity_cap_factor", explicit_cap_factor}};
  return s.dump();
}

// 0.2 s (about the free-fall time of the column's height) was the window of the capped explicit step. At the
// defaults (implicit step, no cap) the column is held to the studies' rest window, 2 s, like the resting layer
// above (chosen 2026-12-05 before the run).
constexpr double kColumnDuration = 2.0;

class RigidColumn : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { result_ = new DirectRun(run_direct(column(kColumnDuration))); }
  static void TearDownTestSuite() {
    delete result_;
    result_ = nullptr;
  }
  static DirectRun* result_;
};
DirectRun* RigidColumn::result_ = nullptr;

TEST_F(RigidColumn, TopMovesLessThanDp) {
  const DirectRun& r = *result_;
  expect_physical_run(r);
  EXPECT_LT(r.max_top_displacement, 0.01) << r.max_top_displacement / 0.01 << " dp";
  std::cout << "[ info     ] column: top " << r.max_top_displacement / 0.01 << " dp, any particle "
            << r.max_displacement / 0.01 << " dp, " << r.steps << " steps, " << r.wall_seconds << " s\n";
}

// With the capped explicit step this failed (2.8 dp, particles at the foot of the column, set moving by the
// viscous wall term); at the defaults (implicit step) no particle moves 1e-6 dp in 2 s (2026-12-05).
TEST_F(RigidColumn, NoParticleMovesMoreThanDp) {
  const DirectRun& r = *result_;
  expect_physical_run(r);
  EXPECT_LT(r.max_displacement, 0.01) << r.max_displacement / 0.01 << " dp";
}

// The viscous force must dissipate: with a high viscosity cap the column above must not gain kinetic energy
// from nowhere. Disabled: with the current wall term (fluid-wall pairs use tau_b = tau_i in the force but the
// wall counts once in the velocity gradient) the power of the viscous force is
//   -sum_i V_i tau_i : (L_i^fluid + 2 L_i^wall),   with tau_i = 2 mu dev sym(L_i^fluid + L_i^wall),
// which is not sign-definite: at factor 100 the column reaches KE = 1.4 J in 0.02 s with no potential energy
// released (initial elastic energy 0.11 J), and a wall-bounded box of random velocities at mu = 1e4 Pa s
// gains 500x its kinetic energy. Counting the wall twice in L as well (i.e. wall velocity mirrored,
// v_b = -v_i) makes the power -sum V tau : L <= 0.
TEST(ViscousWallTerm, CreatesNoEnergyAtHighViscosityCap) {
  const DirectRun r = run_direct(column(0.02, 0.01, 100.0));
  expect_physical_run(r);
  std::cout << "[ info     ] high cap: max KE - released " << r.max_energy_excess << " J (elastic " << r.elastic0
            << " J), any particle " << r.max_displacement / 0.01 << " dp, " << r.steps << " steps\n";
}

}  // namespace
