// numerics.density_floor: a material whose pressure has a floor (friction-HBP: -c cot(phi), 0 when c = 0)
// keeps its density at or above the density where the equation of state reaches that floor. Without it a
// cohesionless flow's continuity density drifts under rho0 with nothing to restore it (the pressure no longer
// changes below the floor): the flume's C6 layout at dp 0.04 m blew up that way (docs/tradeoff.md). Liquids
// have no floor and are left untouched.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>
#include <omp.h>

#include "runout/engine/solver.hpp"
#include "runout/scenarios/scene.hpp"

using json = nlohmann::json;
using namespace runout;

namespace {

// A 0.2 x 0.2 m column collapsing on a 1 m floor (dp 0.01 m: 400 particles), 0.6 s. With the floor on,
// max_dilatancy is 0 so that the floor stands at the tension-floor density itself (a granular material's
// default allowance, 0.1, is tested below).
json column(const json& material, bool floor) {
  json numerics = {{"density_floor", floor}};
  if (floor) numerics["max_dilatancy"] = 0.0;
  return {{"name", "column"},
          {"dimensions", 2},
          {"dp", 0.01},
          {"duration", 0.6},
          {"materials", json::array({material})},
          {"numerics", numerics},
          {"fluid", json::array({{{"min", {0.0, 0.0}}, {"max", {0.2, 0.2}}, {"material", material["name"]}}})},
          {"boundaries", json::array({{{"type", "tank"}, {"min", {0.0, 0.0}}, {"max", {1.0, 0.4}}}})}};
}

json friction(double cohesion) {
  return {{"name", "sand"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0}, {"flow_index", 1.0},
          {"regularisation", 100}, {"friction_angle", 30}, {"cohesion", cohesion}};
}

struct Outcome {
  double min_rho = 1e300;  // over every step, every fluid particle
  double mass_error = 0;
  std::vector<double> final_rho, final_x;
  double rho0 = 0, B = 0;
};

Outcome run(const json& scene) {
  const Scene s = parse_scene(scene.dump());
  Solver<2> solver(std::get<SceneSetup<2>>(s.setup));
  Outcome o;
  o.rho0 = solver.materials()[0].density;
  o.B = solver.config().speed_of_sound * solver.config().speed_of_sound * o.rho0 / solver.config().eos_gamma;
  while (solver.time() < s.duration) {
    solver.step();
    const auto& rho = solver.fluid().rho;
    o.min_rho = std::min(o.min_rho, *std::min_element(rho.begin(), rho.end()));
  }
  const auto mb = solver.mass_balance();
  o.mass_error = static_cast<double>((mb.total_current() - mb.total_initial()) / mb.total_initial());
  o.final_rho = solver.fluid().rho;
  o.final_x = solver.fluid().pos[0];
  return o;
}

}  // namespace

TEST(DensityFloor, CohesionlessFrictionMaterialStaysAtOrAboveRho0) {
  const Outcome on = run(column(friction(0.0), true));
  const Outcome off = run(column(friction(0.0), false));
  EXPECT_GE(on.min_rho, on.rho0);  // the floor is rho0 exactly (the pressure floor is 0)
  EXPECT_EQ(on.mass_error, 0.0);
  // Without the floor the collapsing column's density drifts under rho0 (what the option is for).
  EXPECT_LT(off.min_rho, 0.99 * off.rho0) << "min density without the floor " << off.min_rho;
}

TEST(DensityFloor, CohesiveMaterialIsFlooredWhereTheEquationOfStateReachesItsTension) {
  const double c = 2000.0, phi = 30.0 * M_PI / 180.0;
  const Outcome on = run(column(friction(c), true));
  const double p_min = -c * std::cos(phi) / std::sin(phi);
  const double floor = on.rho0 * std::pow(1.0 + p_min / on.B, 1.0 / 7.0);
  ASSERT_LT(floor, on.rho0);
  EXPECT_GE(on.min_rho, floor * (1 - 1e-12));
  EXPECT_EQ(on.mass_error, 0.0);
}

TEST(DensityFloor, LiquidsAreUntouched) {
  const json water = {{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0.001}};
  omp_set_num_threads(1);  // on two threads the pair sums' order depends on the dynamic schedule: not bitwise
  const Outcome on = run(column(water, true));
  const Outcome off = run(column(water, false));
  // A liquid takes the equation of state's tension: no floor, the same run to the bit.
  EXPECT_EQ(on.final_rho, off.final_rho);
  EXPECT_EQ(on.final_x, off.final_x);
}

TEST(DensityFloor, OptionMustBeABoolean) {
  json s = column(friction(0.0), true);
  s["numerics"]["density_floor"] = "yes";
  try {
    parse_scene(s.dump());
    ADD_FAILURE() << "accepted density_floor \"yes\"";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("numerics.density_floor"), std::string::npos) << e.what();
  }
}

// numerics.max_dilatancy: the floor stands that fraction under the tension-floor density (a granular material
// may dilate, loose against dense packing, before its density is held). The collapsing column drifts under
// 0.99 rho0 without a floor (above), so a 5 % allowance is reached and held.
TEST(DensityFloor, MaxDilatancyLowersTheFloorByThatFraction) {
  json s = column(friction(0.0), true);
  s["numerics"]["max_dilatancy"] = 0.05;
  const Outcome on = run(s);
  EXPECT_GE(on.min_rho, 0.95 * on.rho0 * (1 - 1e-12));
  EXPECT_LT(on.min_rho, 0.99 * on.rho0) << "the material never dilated past 1 %: the allowance was not used";
  EXPECT_EQ(on.mass_error, 0.0);
}

TEST(DensityFloor, MaxDilatancyIsRefusedOutsideItsRangeOrWithoutTheFloor) {
  auto message = [](const json& s) {
    try {
      parse_scene(s.dump());
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  json s = column(friction(0.0), true);
  s["numerics"]["max_dilatancy"] = 0.6;
  const std::string too_big = message(s);
  EXPECT_NE(too_big.find("numerics.max_dilatancy"), std::string::npos) << too_big;
  EXPECT_NE(too_big.find("0.5"), std::string::npos) << too_big;  // the accepted range
  s["numerics"]["max_dilatancy"] = -0.1;
  EXPECT_NE(message(s).find("numerics.max_dilatancy"), std::string::npos);
  s = column(friction(0.0), false);
  s["numerics"]["max_dilatancy"] = 0.1;
  const std::string no_floor = message(s);
  EXPECT_NE(no_floor.find("numerics.max_dilatancy"), std::string::npos) << no_floor;
  EXPECT_NE(no_floor.find("density_floor"), std::string::npos) << no_floor;
}
