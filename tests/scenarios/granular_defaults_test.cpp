// A scene with a granular material defaults to extrapolated walls, the density floor at 10 % dilatancy and
// Fickian particle shifting (GranularDefaults, docs/design.md "Granular defaults"); a liquid's scene keeps DBC
// walls, no floor and no shifting; what
// a scene sets is what it runs; metrics.json reports the choice.
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

json tank_scene(const json& material) {
  json j = json::parse(R"({
    "name": "granular-defaults",
    "dimensions": 2,
    "dp": 0.02,
    "duration": 0.01,
    "fluid": [{"min": [0, 0], "max": [0.2, 0.1], "material": "m"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.6, 0.4]}]
  })");
  j["materials"] = json::array({material});
  j["materials"][0]["name"] = "m";
  return j;
}

const json kFriction = {{"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0},   {"flow_index", 1.0},
                        {"regularisation", 100},      {"friction_angle", 30}, {"cohesion", 0}};
const json kMuI = {{"rheology", "mu-i"},  {"density", 1500},         {"mu_s", 0.38},
                   {"mu_2", 0.64},        {"grain_diameter", 0.001}};
const json kWater = {{"rheology", "newtonian"}, {"density", 1000}};

SolverConfig config_of(const json& scene) {
  return std::get<SceneSetup<2>>(parse_scene(scene.dump()).setup).config;
}

}  // namespace

TEST(GranularDefaults, AGranularMaterialGetsExtrapolatedWallsAndTheFloor) {
  for (const json& material : {kFriction, kMuI}) {
    const SolverConfig cfg = config_of(tank_scene(material));
    EXPECT_EQ(cfg.boundary_pressure, BoundaryPressure::extrapolated) << material["rheology"];
    EXPECT_TRUE(cfg.density_floor) << material["rheology"];
    EXPECT_DOUBLE_EQ(cfg.max_dilatancy, GranularDefaults::max_dilatancy) << material["rheology"];
    EXPECT_EQ(cfg.particle_shifting, ParticleShifting::fickian) << material["rheology"];
    EXPECT_DOUBLE_EQ(cfg.shifting_coefficient, numerics_default::shifting_coefficient) << material["rheology"];
  }
}

TEST(GranularDefaults, ALiquidKeepsDbcWallsAndNoFloor) {
  const SolverConfig cfg = config_of(tank_scene(kWater));
  EXPECT_EQ(cfg.boundary_pressure, BoundaryPressure::dbc);
  EXPECT_FALSE(cfg.density_floor);
  EXPECT_DOUBLE_EQ(cfg.max_dilatancy, 0.0);
  EXPECT_EQ(cfg.particle_shifting, ParticleShifting::none);
}

TEST(GranularDefaults, WhatTheSceneSetsIsWhatItRuns) {
  json j = tank_scene(kFriction);
  j["numerics"] = {{"boundary_pressure", "dbc"}, {"density_floor", false}};
  SolverConfig cfg = config_of(j);
  EXPECT_EQ(cfg.boundary_pressure, BoundaryPressure::dbc);
  EXPECT_FALSE(cfg.density_floor);
  EXPECT_DOUBLE_EQ(cfg.max_dilatancy, 0.0);

  j["numerics"] = {{"max_dilatancy", 0.05}};
  cfg = config_of(j);
  EXPECT_TRUE(cfg.density_floor);
  EXPECT_DOUBLE_EQ(cfg.max_dilatancy, 0.05);

  // A liquid's scene may switch the floor on; it takes no dilatancy unless given one.
  j = tank_scene(kWater);
  j["numerics"] = {{"density_floor", true}};
  cfg = config_of(j);
  EXPECT_TRUE(cfg.density_floor);
  EXPECT_DOUBLE_EQ(cfg.max_dilatancy, 0.0);

  // Shifting: off in a granular scene that says so; on in a liquid's that asks, with its coefficient.
  j = tank_scene(kFriction);
  j["numerics"] = {{"particle_shifting", "none"}};
  EXPECT_EQ(config_of(j).particle_shifting, ParticleShifting::none);
  j = tank_scene(kWater);
  j["numerics"] = {{"particle_shifting", "fickian"}, {"shifting_coefficient", 1.5}};
  cfg = config_of(j);
  EXPECT_EQ(cfg.particle_shifting, ParticleShifting::fickian);
  EXPECT_DOUBLE_EQ(cfg.shifting_coefficient, 1.5);
}

// A coefficient with nothing to size is refused, naming the field and what it needs; so is an unknown shift.
TEST(GranularDefaults, ShiftingFieldsAreChecked) {
  auto expect_refused = [](const json& numerics, const std::string& field, const std::string& said) {
    json j = tank_scene(kWater);
    j["numerics"] = numerics;
    try {
      (void)config_of(j);
      ADD_FAILURE() << numerics.dump() << " was accepted";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(said), std::string::npos) << e.what();
    }
  };
  expect_refused({{"shifting_coefficient", 1.5}}, "numerics.shifting_coefficient", "particle_shifting = fickian");
  expect_refused({{"particle_shifting", "lind"}}, "numerics.particle_shifting", "fickian");
}

TEST(GranularDefaults, MetricsReportTheWallsAndTheFloor) {
  RunOptions opt;
  opt.out_dir = fs::temp_directory_path() / "runout-granular-defaults";
  fs::remove_all(opt.out_dir);
  const RunSummary r = run_scene(parse_scene(tank_scene(kFriction).dump()), opt);
  ASSERT_EQ(r.status, "completed") << r.error;
  const json s = json::parse(r.metrics_json)["settings"];
  EXPECT_EQ(s["boundary_pressure"], "extrapolated");
  EXPECT_EQ(s["density_floor"], true);
  EXPECT_DOUBLE_EQ(s["max_dilatancy"].get<double>(), GranularDefaults::max_dilatancy);
  EXPECT_EQ(s["particle_shifting"], "fickian");
  fs::remove_all(opt.out_dir);
}
