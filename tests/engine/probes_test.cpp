// The point probes in still water, against the hydrostatic answer: a pressure probe, and a face sensor on the
// tank's side wall, read rho0 g (H - z) at a few depths and a depth gauge reads the fill height H, in 2D (the
// shipped hydrostatic tank) and in 3D.
//
// Tolerances, from the model rather than from a run:
//  * pressure: 3 % of rho0 g (H - z) + rho0 g delta. The 3 % is the weakly compressible model's hydrostatic
//    error (docs/validation.md section 1: +2 % at the bed of this tank, scaling as g H / c0^2; the tank test
//    holds every particle to 3 %). delta = g H^2 / (2 c0^2) is how far the column sinks under its own weight
//    (the fluid is compressible): the water above a fixed point is delta shorter than the lattice's H. The
//    Shepard interpolation adds nothing measurable where the kernel's support lies wholly in the water: it
//    reproduces a linear field on a regular lattice, so probes stand at least 2h under the surface and above
//    the floor.
//  * depth: dp. The gauge's surface is where the interpolated fluid fraction falls to 1/2, which for a
//    half-space of fluid is its face; the lattice's top row is dp/2 under that face and the interface is smeared
//    over about h, so the level found moves within a fraction of dp with the particles' arrangement, and the
//    column's sinking delta (about 0.1 dp here) comes on top.
// Each reading is the mean of the samples over the last 0.25 s, several periods of the column's slowest
// acoustic mode (4 H / c0 ~ 0.07 s), which outlives the start-up (docs/validation.md section 1).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include <nlohmann/json.hpp>

#include "runout/engine/monitors.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;

namespace {

// Runs the scene to its duration; returns each monitor's columns averaged over the samples (every 10 steps)
// of the last `window` seconds, and the summary of each at the end.
template <int D>
struct StillWaterRun {
  std::vector<std::vector<real>> mean;
  std::vector<std::vector<std::pair<std::string, real>>> summary;
  real c0 = 0, dp = 0, h = 0;
  double wall = 0;
};

template <int D>
StillWaterRun<D> run_still_water(const json& scene, real window) {
  const Scene s = parse_scene(scene.dump());
  Solver<D> solver(std::get<SceneSetup<D>>(s.setup));
  std::vector<std::unique_ptr<Monitor<D>>> monitors;
  for (const auto& spec : s.monitors) monitors.push_back(make_monitor<D>(spec, solver));
  StillWaterRun<D> out;
  out.c0 = solver.config().speed_of_sound;
  out.dp = s.dp;
  out.h = solver.config().smoothing_length;
  out.mean.resize(monitors.size());
  for (size_t k = 0; k < monitors.size(); ++k) {
    monitors[k]->sample(solver);  // t = 0: before any force evaluation
    out.mean[k].assign(monitors[k]->columns().size(), 0.0);
  }
  int n = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (solver.time() < s.duration) {
    solver.step();
    if (solver.steps() % 10 != 0 || solver.time() < s.duration - window) continue;
    for (size_t k = 0; k < monitors.size(); ++k) {
      const auto row = monitors[k]->sample(solver);
      for (size_t c = 0; c < row.size(); ++c) out.mean[k][c] += row[c];
    }
    ++n;
  }
  out.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GT(n, 10);
  for (auto& m : out.mean)
    for (auto& v : m) v /= n;
  for (const auto& m : monitors) out.summary.push_back(m->summary());
  return out;
}

real summary_value(const std::vector<std::pair<std::string, real>>& sum, const std::string& key) {
  for (const auto& [k, v] : sum)
    if (k == key) return v;
  ADD_FAILURE() << "no summary value " << key;
  return 0;
}

constexpr real kRho = 1000, kG = 9.81;

// Pressure probe k of a run at height z under a surface at H: within 3 % + rho g delta.
template <int D>
void expect_hydrostatic(const StillWaterRun<D>& r, size_t k, real H, real z) {
  const real ref = kRho * kG * (H - z), delta = kG * H * H / (2 * r.c0 * r.c0);
  const real tol = 0.03 * ref + kRho * kG * delta;
  const real p = r.mean[k][0];
  std::printf("  %dD probe at z = %.3f m: %.1f Pa against rho g (H - z) = %.1f Pa (%+.2f %%; tolerance %.1f Pa), "
              "kernel sum %.3f\n",
              D, z, p, ref, 100 * (p - ref) / ref, tol, r.mean[k][1]);
  EXPECT_NEAR(p, ref, tol) << "probe at z = " << z;
  EXPECT_EQ(r.mean[k][2], 1.0) << "wet at every sample";
}

// Face sensor k (face_pressure) at height z on a side wall: the same hydrostatic answer and tolerance. The pair
// force of a consistent SPH pressure term across a plane is p per unit area for a uniform p (the momentum flux),
// and the sensor weights its columns symmetrically about z, so a linear p is read at z.
template <int D>
void expect_face_hydrostatic(const StillWaterRun<D>& r, size_t k, real H, real z) {
  const real ref = kRho * kG * (H - z), delta = kG * H * H / (2 * r.c0 * r.c0);
  const real tol = 0.03 * ref + kRho * kG * delta;
  const real p = r.mean[k][0];
  std::printf("  %dD face sensor at z = %.3f m: %.1f Pa against rho g (H - z) = %.1f Pa (%+.2f %%; "
              "tolerance %.1f Pa)\n",
              D, z, p, ref, 100 * (p - ref) / ref, tol);
  EXPECT_NEAR(p, ref, tol) << "face sensor at z = " << z;
}

}  // namespace

TEST(StillWaterProbes, StillWater2DReadsRhoGDepthAndTheDepthGaugeTheFillHeight) {
  // The shipped hydrostatic tank (0.3 m wide, filled to H = 0.3 m, dp = 0.01 m, h = 1.5 dp, 1 s).
  std::ifstream in(RUNOUT_SOURCE_DIR "/scenarios/validation/hydrostatic_2d.json");
  json scene = json::parse(in);
  const real H = 0.3;
  scene["monitors"] = {
      {{"type", "pressure_probe"}, {"name", "p05"}, {"point", {0.15, 0.05}}},
      {{"type", "pressure_probe"}, {"name", "p15"}, {"point", {0.15, 0.15}}},
      {{"type", "pressure_probe"}, {"name", "p25"}, {"point", {0.15, 0.25}}},
      {{"type", "pressure_probe"}, {"name", "air"}, {"point", {0.15, 0.35}}},
      {{"type", "depth_gauge"}, {"name", "mid"}, {"point", {0.15, 0.0}}},
      {{"type", "depth_gauge"}, {"name", "across"}, {"line", {{0.05, 0.0}, {0.25, 0.0}}}},
      {{"type", "face_pressure"}, {"name", "f05"}, {"structure", "tank"}, {"point", {0.0, 0.05}}, {"normal", {-1, 0}}},
      {{"type", "face_pressure"}, {"name", "f15"}, {"structure", "tank"}, {"point", {0.3, 0.15}}, {"normal", {1, 0}}},
      {{"type", "face_pressure"}, {"name", "f25"}, {"structure", "tank"}, {"point", {0.0, 0.25}}, {"normal", {-1, 0}}}};
  const auto r = run_still_water<2>(scene, 0.25);
  expect_face_hydrostatic(r, 6, H, 0.05);
  expect_face_hydrostatic(r, 7, H, 0.15);
  expect_face_hydrostatic(r, 8, H, 0.25);
  expect_hydrostatic(r, 0, H, 0.05);
  expect_hydrostatic(r, 1, H, 0.15);
  expect_hydrostatic(r, 2, H, 0.25);
  // 0.05 m over the surface, more than the kernel's reach 2h = 0.03 m: dry, no particle in reach.
  EXPECT_EQ(r.mean[3][0], 0.0);
  EXPECT_EQ(r.mean[3][1], 0.0);
  EXPECT_EQ(r.mean[3][2], 0.0);
  EXPECT_EQ(summary_value(r.summary[3], "wet_fraction"), 0.0);
  EXPECT_EQ(summary_value(r.summary[3], "arrival_time_s"), -1.0);
  // Wet from the first sample (t = 0, before any step: pressures from the hydrostatic start's densities).
  EXPECT_EQ(summary_value(r.summary[0], "arrival_time_s"), 0.0);
  EXPECT_EQ(summary_value(r.summary[0], "wet_fraction"), 1.0);
  std::printf("  2D depth gauge: %.4f m at x = 0.15 m, %.4f m the deepest station of the line at %.3f m along it, "
              "against H = %.3f m (tolerance dp = %.3f m); surface height %.4f m; %.1f s wall\n",
              r.mean[4][0], r.mean[5][0], r.mean[5][2], H, r.dp, r.mean[4][1], r.wall);
  EXPECT_NEAR(r.mean[4][0], H, r.dp);
  EXPECT_NEAR(r.mean[4][1], H, r.dp);  // the floor is at 0: surface height = depth
  EXPECT_NEAR(r.mean[5][0], H, r.dp);
  EXPECT_GE(r.mean[5][2], 0.0);
  EXPECT_LE(r.mean[5][2], 0.2);
  EXPECT_NEAR(summary_value(r.summary[4], "final_depth_m"), H, r.dp);
  EXPECT_NEAR(summary_value(r.summary[4], "max_depth_m"), H, 2 * r.dp);  // the start-up ripple included
}

TEST(StillWaterProbes, StillWater3DReadsRhoGDepthAndTheDepthGaugeTheFillHeight) {
  // A 0.2 m x 0.2 m tank filled to H = 0.2 m at dp = 0.02 m (10 x 10 x 10 particles), the 2D tank's numerics.
  const real H = 0.2;
  json scene = json::parse(R"({
    "dimensions": 3, "dp": 0.02, "duration": 0.8,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0}],
    "numerics": {"kernel": "wendland", "smoothing_ratio": 1.5, "artificial_viscosity": 1.0,
                 "density_diffusion": "fourtakas", "density_diffusion_delta": 0.1},
    "fluid": [{"min": [0, 0, 0], "max": [0.2, 0.2, 0.2], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0, 0], "max": [0.2, 0.2, 0.3], "layers": 3, "tag": "tank"}]
  })");
  // h = 0.03 m: probes at least 2h = 0.06 m from the floor and the surface.
  scene["monitors"] = {
      {{"type", "pressure_probe"}, {"name", "p06"}, {"point", {0.1, 0.1, 0.06}}},
      {{"type", "pressure_probe"}, {"name", "p10"}, {"point", {0.1, 0.1, 0.10}}},
      {{"type", "pressure_probe"}, {"name", "p14"}, {"point", {0.1, 0.1, 0.14}}},
      {{"type", "depth_gauge"}, {"name", "mid"}, {"point", {0.1, 0.1, 0.0}}},
      {{"type", "depth_gauge"}, {"name", "diagonal"}, {"line", {{0.06, 0.06}, {0.14, 0.14}}}, {"floor", 0.0}},
      {{"type", "face_pressure"}, {"name", "f06"}, {"structure", "tank"}, {"point", {0.0, 0.1, 0.06}},
       {"normal", {-1, 0, 0}}},
      {{"type", "face_pressure"}, {"name", "f10"}, {"structure", "tank"}, {"point", {0.1, 0.2, 0.10}},
       {"normal", {0, 1, 0}}}};
  const auto r = run_still_water<3>(scene, 0.25);
  expect_face_hydrostatic(r, 5, H, 0.06);
  expect_face_hydrostatic(r, 6, H, 0.10);
  expect_hydrostatic(r, 0, H, 0.06);
  expect_hydrostatic(r, 1, H, 0.10);
  expect_hydrostatic(r, 2, H, 0.14);
  std::printf("  3D depth gauge: %.4f m at the centre, %.4f m the deepest station of the diagonal, against H = %.3f m "
              "(tolerance dp = %.3f m); %.1f s wall\n",
              r.mean[3][0], r.mean[4][0], H, r.dp, r.wall);
  EXPECT_NEAR(r.mean[3][0], H, r.dp);
  EXPECT_NEAR(r.mean[4][0], H, r.dp);
  EXPECT_NEAR(summary_value(r.summary[3], "final_depth_m"), H, r.dp);
}
