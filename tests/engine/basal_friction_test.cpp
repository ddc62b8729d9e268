// Basal friction of thin frictional sheets. A friction-HBP layer on a plane of slope theta, periodic along the
// slope, has a basal shear stress of sin(phi) times the basal normal stress once it yields, whatever happens
// inside it: its mean velocity grows at exactly a = g (sin(theta) - cos(theta) sin(phi)). A sheet one or two
// particles thick has no resolved pressure of its own (its SPH pressure is near zero), so the bed's Coulomb
// friction against the wall's normal push is what carries this (docs/design.md, "Basal friction"); before it
// existed such sheets either slid almost freely or locked into the bed lattice (docs/validation.md).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/engine/solver.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

constexpr double kG = 9.81, kDeg = 3.14159265358979323846 / 180.0;

struct Slide {
  double mean_speed = 0;  // sqrt(2 KE / m) at the end
  std::string status;
};

// A layer `layers` particles thick (dp = 1 m) on a plane of `slope` degrees, gravity tilted, 12 m period; with
// layers = 0, three lone particles 4 dp apart (beyond each other's kernel support).
Slide slide(int layers, double slope, double phi, const std::string& boundary, double duration) {
  const double a = slope * kDeg;
  json fluid = json::array();
  if (layers > 0)
    fluid.push_back({{"min", {0.0, 0.0}}, {"max", {12.0, static_cast<double>(layers)}}, {"material", "debris"}});
  for (int k = 0; layers == 0 && k < 3; ++k)
    fluid.push_back({{"min", {4.0 * k, 0.0}}, {"max", {4.0 * k + 1.0, 1.0}}, {"material", "debris"}});
  const json s = {
      {"name", "sheet"},
      {"dimensions", 2},
      {"dp", 1.0},
      {"duration", duration},
      {"gravity", {kG * std::sin(a), -kG * std::cos(a)}},
      {"materials",
       {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0}, {"flow_index", 1.05},
         {"regularisation", 100}, {"friction_angle", phi}, {"cohesion", 0}}}},
      {"numerics", {{"speed_of_sound", 120}, {"boundary_pressure", boundary}}},
      {"fluid", fluid},
      {"boundaries", {{{"type", "plane"}, {"origin", {0.0, 0.0}}, {"length", 12.0}}}},
      {"domain", {{"min", {0.0, -5.0}}, {"max", {12.0, 40.0}}, {"periodic", {true, false}}}},
      {"output", {{"series_interval", 0.1}}}};
  RunOptions opt;
  opt.out_dir = fs::temp_directory_path() / ("runout-sheet-" + std::to_string(layers) + boundary + std::to_string(phi));
  fs::remove_all(opt.out_dir);
  const RunSummary r = run_scene(parse_scene(s.dump()), opt);
  const json m = json::parse(r.metrics_json);
  Slide out;
  out.status = r.status;
  out.mean_speed = std::sqrt(2.0 * m["energy"]["kinetic_final_j"].get<double>() / m["mass"]["initial_kg"].get<double>());
  fs::remove_all(opt.out_dir);
  return out;
}

}  // namespace

class ThinSheet : public ::testing::TestWithParam<std::tuple<int, std::string>> {};

// Measured (2026-11-28): 1 layer 4.43 m/s, 2 layers 4.46-4.47, 8 layers 4.68, against 4.39 m/s at 3 s. The
// mean speed cannot exceed the rigid-slide value by physics (the basal force is fixed); 10 % allows for the
// regularised friction near zero slip and the lattice's uneven push.
TEST_P(ThinSheet, SlidesAtTheCoulombRate) {
  const auto [layers, boundary] = GetParam();
  const double slope = 27, phi = 20, T = 3.0;
  const Slide s = slide(layers, slope, phi, boundary, T);
  ASSERT_EQ(s.status, "completed");
  const double rigid = kG * (std::sin(slope * kDeg) - std::cos(slope * kDeg) * std::sin(phi * kDeg)) * T;
  EXPECT_NEAR(s.mean_speed, rigid, 0.10 * rigid) << layers << " layers, " << boundary;
}

INSTANTIATE_TEST_SUITE_P(Layers, ThinSheet,
                         ::testing::Combine(::testing::Values(1, 2, 8), ::testing::Values("extrapolated", "dbc")),
                         [](const auto& info) {
                           return std::to_string(std::get<0>(info.param)) + "_" + std::get<1>(info.param);
                         });

// A sheet with ends: `particles` long, one thick, on a plane of 30 degrees (gravity tilted, no periodic axis).
// Its ends have flow on one side only, so the extrapolated wall pressure under them sees its fluid on one side.
// With Adami's hydrostatic term along all of g the wall particles downslope of an end pushed harder than those
// upslope: a lone particle slid at 1.91 m/s after 3 s and a 6-particle sheet at 4.74 m/s, against the rigid
// slide's 6.00 m/s. With the term across the wall only (its normal), 6.03 and 6.06 m/s (2026-12-02). The
// tolerance is ThinSheet's (10 %); a sheet with ends also spreads a little, which adds to its mean speed.
namespace {
double finite_sheet_speed(int particles) {
  const double a = 30 * kDeg, T = 3.0;
  const json s = {
      {"name", "sheet-with-ends"},
      {"dimensions", 2},
      {"dp", 1.0},
      {"duration", T},
      {"gravity", {kG * std::sin(a), -kG * std::cos(a)}},
      {"materials",
       {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0}, {"flow_index", 1.05},
         {"regularisation", 100}, {"friction_angle", 20}, {"cohesion", 0}}}},
      {"numerics", {{"speed_of_sound", 120}, {"boundary_pressure", "extrapolated"}}},
      {"fluid", {{{"min", {5.0, 0.0}}, {"max", {5.0 + particles, 1.0}}, {"material", "debris"}}}},
      {"boundaries", {{{"type", "plane"}, {"origin", {0.0, 0.0}}, {"length", 60.0}}}},
      {"domain", {{"min", {-1.0, -5.0}}, {"max", {61.0, 40.0}}}},
      {"output", {{"series_interval", 0.5}}}};
  RunOptions opt;
  opt.out_dir = fs::temp_directory_path() / ("runout-sheet-ends-" + std::to_string(particles));
  fs::remove_all(opt.out_dir);
  const RunSummary r = run_scene(parse_scene(s.dump()), opt);
  EXPECT_EQ(r.status, "completed");
  const json m = json::parse(r.metrics_json);
  fs::remove_all(opt.out_dir);
  return std::sqrt(2.0 * m["energy"]["kinetic_final_j"].get<double>() / m["mass"]["initial_kg"].get<double>());
}
}  // namespace

class SheetWithEnds : public ::testing::TestWithParam<int> {};

TEST_P(SheetWithEnds, SlidesAtTheCoulombRate) {
  const double slope = 30 * kDeg, phi = 20 * kDeg, T = 3.0;
  const double rigid = kG * (std::sin(slope) - std::cos(slope) * std::sin(phi)) * T;
  EXPECT_NEAR(finite_sheet_speed(GetParam()), rigid, 0.10 * rigid) << GetParam() << " particles";
}

INSTANTIATE_TEST_SUITE_P(Length, SheetWithEnds, ::testing::Values(1, 6));

// sin(45 deg) = 0.71 > tan(27 deg) = 0.51: a one-particle sheet holds on the slope (mean speed after 1 s under
// 2 % of the 4.4 m/s it would reach on a frictionless bed).
TEST(ThinSheetAtRest, HoldsWhenSinPhiExceedsTanSlope) {
  const Slide s = slide(1, 27, 45, "extrapolated", 1.0);
  ASSERT_EQ(s.status, "completed");
  EXPECT_LT(s.mean_speed, 0.02 * kG * std::sin(27 * kDeg) * 1.0);
}

// A lone particle has no pressure of its own. Resting at about 1 dp above an (extrapolated-pressure) bed the
// wall's push carries its weight; pressed closer than kWallContact dp (a landing, a jam) the wall contact
// takes part of it, by removing the approach velocity. Coulomb friction acts on both parts of the normal
// force, so a particle sliding at v0 stops after v0^2 / (2 sin(phi) g) wherever it starts. Before friction
// acted on the contact's impulse, the particle started at 0.6 dp slid 27.2 mm against the 25.5 mm of
// Coulomb (+6.8 %); now 25.5 mm from both heights. 3 %: the slip regularisation (v_slip = 3 mm/s) and the
// time integration, measured at 0.05 %.
namespace {
double lone_particle_slide(double phi, double start_height_dp) {
  SceneSetup<2> s;
  const double dp = 0.01;
  s.config.dp = dp;
  s.config.smoothing_length = 1.5 * dp;
  s.config.speed_of_sound = 20;
  s.config.gravity = {0, -kG, 0};
  s.config.boundary_density = 2000;
  s.config.boundary_pressure = BoundaryPressure::extrapolated;
  MaterialParams m;
  m.name = "grain";
  m.rheology = "friction-hbp";
  m.density = 2000;
  m.set("viscosity", 1e-3);
  m.set("friction_angle", phi);
  s.materials.push_back(m);
  for (int k = -30; k <= 80; ++k)
    for (int l = 0; l < 3; ++l) s.boundary.add(Vec<2>(k * dp, -l * dp), 2000.0, 2000.0 * dp * dp, 0, 1);
  s.fluid.add(Vec<2>(0.0, start_height_dp * dp), 2000.0, 2000.0 * dp * dp, 0, 0);
  s.fluid.vel[0].back() = 0.5;
  Solver<2> solver(std::move(s));
  while (solver.time() < 0.3) solver.step();  // it stops by 0.1 s
  EXPECT_LT(std::abs(solver.fluid().vel[0][0]), 1e-3);
  return solver.fluid().pos[0][0];
}
}  // namespace

class LoneParticle : public ::testing::TestWithParam<double> {};

TEST_P(LoneParticle, StopsAfterTheCoulombSlidingDistance) {
  const double phi = 30, v0 = 0.5;
  const double expected = v0 * v0 / (2 * std::sin(phi * kDeg) * kG);  // 25.5 mm
  EXPECT_NEAR(lone_particle_slide(phi, GetParam()), expected, 0.03 * expected);
}

INSTANTIATE_TEST_SUITE_P(StartHeight, LoneParticle, ::testing::Values(0.6, 1.0), [](const auto& info) {
  return info.param < 0.75 ? std::string("InContact") : std::string("OnThePush");
});
