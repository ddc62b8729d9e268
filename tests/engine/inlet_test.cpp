// Velocity inlets: a steady channel flow fed by an inlet passes the inflow through a section downstream
// (issue 4: Q equal to the inflow within 5%), mass is conserved to rounding with inflow and outflow, and a
// hydrograph (discharge against time) brings in its integral.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "runout/engine/monitors.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;

TEST(Inlet, SteadyChannelFlowPassesTheInflowThroughASection) {
  // 2D supercritical inflow, depth H = 0.04 m at U = 1.5 m/s (Froude 2.4, so the inlet may impose both),
  // onto a horizontal bed 0.8 m long that ends in a free overfall (an outflow face). Once the front has left
  // the domain the flow is steady and the discharge at every section is the inflow, U H = 0.06 m2/s, by
  // mass conservation: nothing is stored between the inlet and the section any more.
  const json scene = json::parse(R"({
    "dimensions": 2, "dp": 0.008, "duration": 1.6,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
    "numerics": {"artificial_viscosity": 0.02},
    "inlets": [{"name": "In", "material": "water", "direction": "+x", "at": 0.0, "min": [0.0], "max": [0.04],
                "speed": 1.5}],
    "boundaries": [{"type": "plane", "origin": [-0.1, 0], "length": 0.2, "angle": 0, "tag": "bed"},
                   {"type": "plane", "origin": [0.1, 0], "length": 0.72, "angle": 10, "tag": "chute"}],
    "domain": {"min": [-0.2, -0.2], "max": [0.8, 0.5], "outflow": ["x+"]},
    "monitors": [{"type": "section", "name": "S1", "x": 0.3}, {"type": "section", "name": "S2", "x": 0.6}]
  })");
  Scene s = parse_scene(scene.dump());
  Solver<2> solver(std::get<SceneSetup<2>>(s.setup));
  auto s1 = make_monitor<2>(s.monitors[0], solver);
  auto s2 = make_monitor<2>(s.monitors[1], solver);
  const real q_in = 1.5 * 0.04;
  real v1_start = 0, v2_start = 0, out_start = 0, t_start = 0;
  bool window = false;
  while (solver.time() < 1.6) {
    solver.step();
    s1->after_step(solver);
    s2->after_step(solver);
    if (!window && solver.time() >= 1.0) {
      window = true;
      t_start = solver.time();
      v1_start = s1->summary()[3].second;
      v2_start = s2->summary()[3].second;
      out_start = static_cast<double>(solver.mass_balance().total_outflow());
    }
  }
  const real T = solver.time() - t_start;
  const real q1 = (s1->summary()[3].second - v1_start) / T;
  const real q2 = (s2->summary()[3].second - v2_start) / T;
  const real q_out = (static_cast<double>(solver.mass_balance().total_outflow()) - out_start) / 1000.0 / T;
  EXPECT_NEAR(q1, q_in, 0.05 * q_in);
  EXPECT_NEAR(q2, q_in, 0.05 * q_in);
  EXPECT_NEAR(q_out, q_in, 0.05 * q_in);
  // Arrival at S2, 0.6 m down: the front of a flow pushed out at U runs ahead of it like a dam-break front,
  // at most U + 2 sqrt(g H) = 2.75 m/s, plus g sin(10 deg) t = 0.6 m/s from the chute over that time; the
  // bulk, at U or faster on the chute, is there by 0.6 / 1.5 = 0.4 s.
  const real t0 = s2->summary()[2].second;
  EXPECT_GT(t0, 0.6 / (2.75 + 0.6));
  EXPECT_LT(t0, 0.4);

  // Mass: the inlet brought in U H t of water to within one column of particles, and initial + inflow =
  // current + outflow to rounding.
  const auto mb = solver.mass_balance();
  const double in = static_cast<double>(mb.total_inflow());
  EXPECT_NEAR(in, 1000.0 * q_in * solver.time(), 1000.0 * 0.04 * 0.008 + 1e-9);
  EXPECT_EQ(mb.total_initial(), 0.0L);
  EXPECT_NEAR(static_cast<double>(mb.total_current() + mb.total_outflow()), in, 1e-9 * in);
}

TEST(Inlet, AHydrographBringsInItsIntegralIn3DWithEitherIntegrator) {
  // 3D channel 0.1 m wide fed by a discharge that ramps 0 -> 2 l/s over 0.2 s and holds: after 0.4 s the
  // inlet has brought 0.2 + 0.4 = 0.6 l (half the ramp plus the plateau), to within one row of particles.
  for (const char* integrator : {"symplectic", "verlet"}) {
    const json scene = json::parse(std::string(R"({
      "dimensions": 3, "dp": 0.01, "duration": 0.4,
      "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
      "numerics": {"integrator": ")") + integrator + R"(", "artificial_viscosity": 0.02},
      "inlets": [{"name": "In", "material": "water", "direction": "+x", "at": 0.0,
                  "min": [0.0, 0.0], "max": [0.1, 0.04], "discharge": [[0, 0], [0.2, 0.002]]}],
      "boundaries": [{"type": "flume", "origin": [-0.1, 0, 0], "length": 0.8, "width": 0.1, "wall_height": 0.1,
                      "angle": 0, "tag": "flume"}],
      "domain": {"min": [-0.2, -0.1, -0.1], "max": [0.7, 0.2, 0.4], "outflow": ["x+"]}
    })");
    Scene s = parse_scene(scene.dump());
    Solver<3> solver(std::get<SceneSetup<3>>(s.setup));
    while (solver.time() < 0.4) solver.step();
    const real t = solver.time();
    const real expected = 1000.0 * (0.5 * 0.2 * 0.002 + (t - 0.2) * 0.002);
    const auto mb = solver.mass_balance();
    const double in = static_cast<double>(mb.total_inflow());
    const double row = 1000.0 * 0.1 * 0.04 * 0.01;  // one row of buffer particles across the opening
    EXPECT_NEAR(in, expected, row) << integrator;
    EXPECT_NEAR(static_cast<double>(mb.total_current() + mb.total_outflow()), in, 1e-9 * in) << integrator;
    // The new flow stays in the channel: no particle below the bed or outside the walls.
    const auto& f = solver.fluid();
    for (size_t i = 0; i < f.size(); ++i) {
      ASSERT_GT(f.pos[2][i], -0.005) << integrator;
      ASSERT_GT(f.pos[1][i], -0.005) << integrator;
      ASSERT_LT(f.pos[1][i], 0.105) << integrator;
    }
  }
}

namespace {
// A 3D inlet of `depth` at `speed` parsed as an axis-aligned one across a flume, for the tests below to turn
// and tilt: the engine's inlet is a plane of any horizontal normal with a floor per lane.
Scene inlet_on_flume(real angle_deg, real width, real duration) {
  const real drop = 0.1 * std::tan(angle_deg * M_PI / 180);  // the bed passes z = 0 at x = 0
  json scene = json::parse(R"({
    "dimensions": 3, "dp": 0.01,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
    "numerics": {"artificial_viscosity": 0.02},
    "inlets": [{"name": "In", "material": "water", "direction": "+x", "at": 0.0,
                "min": [0.0, 0.0], "max": [0.1, 0.03], "speed": 1.0}],
    "domain": {"min": [-0.2, -0.1, -0.3], "max": [0.8, 0.7, 0.3], "outflow": ["x+"]}
  })");
  scene["duration"] = duration;
  scene["boundaries"] = json::array({{{"type", "flume"}, {"origin", {-0.1, 0, drop}}, {"length", 0.9},
                                      {"width", width}, {"wall_height", 0.1}, {"angle", angle_deg},
                                      {"tag", "flume"}}});
  return parse_scene(scene.dump());
}
}  // namespace

TEST(Inlet, ABufferFollowsASlopingFloorAndBringsInSpeedTimesArea) {
  // A 10 degree flume: the inlet's floor falls at tan(10 deg) along its normal, as the bed does. The buffer
  // stands on the bed (each particle between the floor and the opening's top), the inflow is speed x area
  // to within one row of particles, and nothing goes under the bed.
  const real angle = 10, tilt = std::tan(angle * M_PI / 180);
  Scene s = inlet_on_flume(angle, 0.1, 0.25);
  auto setup = std::get<SceneSetup<3>>(s.setup);
  ASSERT_EQ(setup.inlets.size(), 1u);
  ASSERT_EQ(setup.inlets[0].lanes(), 10u);
  setup.inlets[0].slope.assign(10, -tilt);
  Solver<3> solver(setup);
  const auto& f = solver.fluid();
  size_t buffer = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    if (!Solver<3>::is_inlet_buffer(f.tag[i])) continue;
    ++buffer;
    const real above = f.pos[2][i] + tilt * f.pos[0][i];  // height above the floor line z = -tan(a) x
    EXPECT_GT(above, 0.0);
    EXPECT_LT(above, 0.03);
    EXPECT_NEAR(f.vel[2][i], -tilt * f.vel[0][i], 1e-12);  // moving along the floor
  }
  EXPECT_EQ(buffer, 10u * 3u * static_cast<size_t>(inlet_buffer_layers(solver.config())));
  while (solver.time() < 0.25) solver.step();
  const double in = static_cast<double>(solver.mass_balance().total_inflow());
  const double row = 1000.0 * 0.1 * 0.03 * 0.01;
  EXPECT_NEAR(in, 1000.0 * 1.0 * 0.1 * 0.03 * solver.time(), row);
  for (size_t i = 0; i < f.size(); ++i) ASSERT_GT(f.pos[2][i] + tilt * f.pos[0][i], -0.005);
}

TEST(Inlet, AnInletTurnedAcrossTheGridDeliversAlongItsNormal) {
  // An inlet whose normal is 30 degrees off x, onto a flat bed 0.6 m wide: the set-up is mirror-symmetric
  // about the normal until the flow meets a side wall (both are >= 0.29 m across the flow from the opening's
  // edges, more than a front spreading at 2 sqrt(g H) = 1.1 m/s covers in 0.2 s), so the flow's horizontal
  // momentum lies along the normal: the bed's shear and the pressure spread it sideways symmetrically.
  // 3 degrees allows for the particle lattice, which is not symmetric about a turned axis.
  Scene s = inlet_on_flume(0, 0.6, 0.2);
  auto setup = std::get<SceneSetup<3>>(s.setup);
  auto& in = setup.inlets[0];
  const real a = 30 * M_PI / 180;
  in.normal = Vec<3>(std::cos(a), std::sin(a), 0);
  in.across = Vec<3>(-std::sin(a), std::cos(a), 0);
  in.origin = Vec<3>(0.3, 0.25, 0);
  Solver<3> solver(setup);
  while (solver.time() < 0.2) solver.step();
  const double inflow = static_cast<double>(solver.mass_balance().total_inflow());
  EXPECT_NEAR(inflow, 1000.0 * 0.1 * 0.03 * solver.time(), 1000.0 * 0.1 * 0.03 * 0.01);
  const auto& f = solver.fluid();
  Vec<3> momentum = Vec<3>::Zero();
  for (size_t i = 0; i < f.size(); ++i) {
    ASSERT_GT(f.pos[2][i], -0.005);
    if (Solver<3>::is_inlet_buffer(f.tag[i])) continue;
    EXPECT_GE(in.along(f.position(i)), -0.5 * solver.config().dp);  // new flow only downstream of the plane
    momentum += f.mass[i] * f.velocity(i);
  }
  const real heading = std::atan2(momentum[1], momentum[0]) * 180 / M_PI;
  EXPECT_NEAR(heading, 30.0, 3.0);
}
