// Monitors on cases with known answers: the hydrostatic load on a wall, a section that counts exactly the
// volume that went past it, a column that runs off a slope fully counted downstream, and a 3D section that
// counts the same whichever order its points are listed in.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "runout/engine/monitors.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;

namespace {

real volume_beyond(const ParticleArrays<2>& f, real x0) {
  real v = 0;
  for (size_t i = 0; i < f.size(); ++i)
    if (f.pos[0][i] >= x0) v += f.mass[i] / f.rho[i];
  return v;
}

}  // namespace

TEST(StructureLoad, HydrostaticForceOnAWallIsHalfRhoGHSquared) {
  // 2D tank 0.3 m wide filled to H = 0.3 m; its right wall is a separate tagged block.
  const json scene = json::parse(R"({
    "dimensions": 2, "dp": 0.01, "duration": 1.0,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0}],
    "numerics": {"artificial_viscosity": 1.0},
    "fluid": [{"min": [0, 0], "max": [0.3, 0.3], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.3, 0.4], "open": ["x+", "top"], "tag": "tank"},
                   {"type": "block", "min": [0.3, -0.03], "max": [0.33, 0.4], "tag": "wall"}],
    "monitors": [{"type": "structure_load", "name": "wall", "structure": "wall", "normal": [1, 0]}]
  })");
  Scene s = parse_scene(scene.dump());
  ASSERT_EQ(s.monitors.size(), 1u);
  Solver<2> solver(std::get<SceneSetup<2>>(s.setup));
  auto load = make_monitor<2>(s.monitors[0], solver);
  // As a run does: the monitor sees every step (it evaluates the load ~50 times a load-cell window).
  while (solver.time() < 1.0) solver.step(), load->after_step(solver);
  // Average the last 0.2 s of samples to remove the remaining acoustic ripple.
  real sum = 0;
  int n = 0;
  while (solver.time() < 1.2) {
    solver.step();
    load->after_step(solver);
    if (solver.steps() % 10 == 0) sum += load->sample(solver)[0], ++n;
  }
  const real expected = 0.5 * 1000 * 9.81 * 0.3 * 0.3;  // per metre of wall
  EXPECT_NEAR(sum / n, expected, 0.05 * expected);
  // Mean pressure on the wetted face: half the bottom pressure, rho g H / 2 (the face wetted up to about H).
  const auto row = load->sample(solver);
  EXPECT_NEAR(row[1], 0.5 * 1000 * 9.81 * 0.3, 0.1 * 0.5 * 1000 * 9.81 * 0.3);
  EXPECT_NEAR(row[3], 0.3, 0.03);  // wetted face height ~ H (one spacing)
  // The load cell's window by default is the time a run-up takes to climb the wall and stall, sqrt(2H/g),
  // H the wall's height (0.43 m of block, its particles' centres within one spacing of it).
  real window = -1;
  for (const auto& [k, v] : load->summary())
    if (k == "load_window_s") window = v;
  EXPECT_NEAR(window, std::sqrt(2 * 0.43 / 9.81), std::sqrt(2 * 0.43 / 9.81) - std::sqrt(2 * 0.40 / 9.81));
}

TEST(SectionGauge, VolumePassedIsExactlyTheVolumeOnTheDownstreamSide) {
  // Dam break in a closed tank: the water runs past x = 1.5 m, hits the far wall and sloshes back. At any
  // time the net volume passed is the volume beyond the section (nothing started there).
  const json scene = json::parse(R"({
    "dimensions": 2, "dp": 0.02, "duration": 1.2,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0}],
    "numerics": {"artificial_viscosity": 0.02, "speed_of_sound": 50},
    "fluid": [{"min": [0, 0], "max": [0.6, 0.6], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [3.22, 1.8], "tag": "tank"}],
    "monitors": [{"type": "section", "name": "S", "x": 1.5}]
  })");
  Scene s = parse_scene(scene.dump());
  Solver<2> solver(std::get<SceneSetup<2>>(s.setup));
  auto gauge = make_monitor<2>(s.monitors[0], solver);
  real peak = 0;
  int checks = 0;
  while (solver.time() < 1.2) {
    solver.step();
    gauge->after_step(solver);
    if (solver.steps() % 100 == 0) {
      const auto row = gauge->sample(solver);
      peak = std::max(peak, row[0]);
      // Each particle's volume is counted at its crossing; its density has moved since by the weak
      // compressibility only (well under 1%).
      const real beyond = volume_beyond(solver.fluid(), 1.5);
      EXPECT_NEAR(row[1], beyond, 0.005 * beyond + 1e-12) << "t = " << solver.time();
      ++checks;
    }
  }
  EXPECT_GT(checks, 3);
  EXPECT_GT(volume_beyond(solver.fluid(), 1.5), 0.1);  // a good part of the 0.36 m2 went past
  // Arrival: the front of a dry-bed dam break covers 1.5 - 0.6 = 0.9 m at about 2 sqrt(g H) = 4.9 m/s after
  // a start-up; the gauge must not see anything before 0.9 / 4.9 = 0.18 s.
  const auto sum = gauge->summary();
  EXPECT_EQ(sum[2].first, "arrival_time_s");
  EXPECT_GT(sum[2].second, 0.18);
  EXPECT_LT(sum[2].second, 0.6);
  // The hydrograph's window: the time the 0.6 m column takes to fall its own depth, sqrt(2 x 0.6 / g) (the
  // column's mean depth is its 30 rows of 0.02 m, counted exactly).
  EXPECT_EQ(sum[5].first, "discharge_window_s");
  EXPECT_NEAR(sum[5].second, std::sqrt(2 * 0.6 / 9.81), 1e-9);
}

TEST(SectionGauge, AColumnRunningOffASlopeIsFullyCountedDownstream) {
  // A 0.2 m x 0.2 m column on a 30 degree plane; the domain ends at x = 2.0 m with an outflow face, so all
  // the water leaves. A section at x = 1.5 m must count all of it, as the outflow does.
  const json scene = json::parse(R"({
    "dimensions": 2, "dp": 0.01, "duration": 2.0,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.01}],
    "numerics": {"speed_of_sound": 60},
    "fluid": [{"origin": [0, 0], "size": [0.2, 0.2], "angle": 30, "material": "water"}],
    "boundaries": [{"type": "plane", "origin": [0, 0], "length": 2.2, "angle": 30, "tag": "bed"},
                   {"type": "block", "origin": [-0.041, -0.011], "size": [0.03, 0.4], "angle": 30, "tag": "back"}],
    "domain": {"min": [-0.5, -2.0], "max": [2.0, 1.0], "outflow": ["x+"]},
    "monitors": [{"type": "section", "name": "S", "x": 1.5}]
  })");
  Scene s = parse_scene(scene.dump());
  Solver<2> solver(std::get<SceneSetup<2>>(s.setup));
  auto gauge = make_monitor<2>(s.monitors[0], solver);
  real v0 = 0;
  for (size_t i = 0; i < solver.fluid().size(); ++i) v0 += solver.fluid().mass[i] / solver.fluid().rho[i];
  while (solver.time() < 2.0 && solver.fluid().size() > 0) {
    solver.step();
    gauge->after_step(solver);
  }
  ASSERT_EQ(solver.fluid().size(), 0u) << "water still on the slope at t = " << solver.time();
  const real passed = gauge->summary()[3].second;
  // Volumes are m / rho at the crossing: within the weak compressibility (well under 1%) of the start.
  EXPECT_NEAR(passed, v0, 0.01 * v0);
  const auto mb = solver.mass_balance();
  EXPECT_NEAR(passed * 1000.0, static_cast<double>(mb.total_outflow()), 0.01 * static_cast<double>(mb.total_outflow()));
}

TEST(SectionGauge, ALineBesideTheReleaseCountsDownstreamWhicheverWayItIsListed) {
  // 3D dam break in a channel 0.4 m wide. The section is a diagonal from (0.6, 0) to (1.0, 0.4): it spans
  // the channel, but no release particle (x <= 0.2) projects within its ends, so the upstream side cannot
  // be told by counting the release on each side; it is the side of the flow's centroid. Listed in either
  // order, the gauge must count the volume that has gone past the line, positive.
  const std::string base = R"({
    "dimensions": 3, "dp": 0.04, "duration": 0.5,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0}],
    "numerics": {"artificial_viscosity": 0.05, "speed_of_sound": 20},
    "fluid": [{"min": [0, 0, 0], "max": [0.2, 0.4, 0.3], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0, 0], "max": [1.6, 0.4, 0.4], "tag": "tank"}],
    "monitors": [{"type": "section", "name": "A", "line": [[0.6, 0.0], [1.0, 0.4]]},
                 {"type": "section", "name": "B", "line": [[1.0, 0.4], [0.6, 0.0]]}]
  })";
  Scene s = parse_scene(base);
  ASSERT_EQ(s.monitors.size(), 2u);
  Solver<3> solver(std::get<SceneSetup<3>>(s.setup));
  auto a = make_monitor<3>(s.monitors[0], solver);
  auto b = make_monitor<3>(s.monitors[1], solver);
  while (solver.time() < 0.5) {
    solver.step();
    a->after_step(solver);
    b->after_step(solver);
  }
  // Volume beyond the line x - y = 0.6 (bulk volume m / rho0, as the gauge counts it).
  const auto& f = solver.fluid();
  real beyond = 0;
  for (size_t i = 0; i < f.size(); ++i)
    if (f.pos[0][i] - f.pos[1][i] > 0.6) beyond += f.mass[i] / 1000.0;
  ASSERT_GT(beyond, 0.002) << "too little water went past the line for the check to mean anything";
  const real passed_a = a->summary()[3].second, passed_b = b->summary()[3].second;
  // Every particle beyond the line crossed it within the line's ends (the line spans the channel).
  EXPECT_NEAR(passed_a, beyond, 1e-9);
  EXPECT_NEAR(passed_b, beyond, 1e-9);
}

// A monitor type is one file: its class, its fields and its reader. Every registered type reads its own geometry,
// and a spec's numbers are the type's declared ones: as given, else the declared default, and no other key.
TEST(MonitorTypes, EveryTypeReadsItsOwnGeometryAndDeclaresItsNumbers) {
  for (const MonitorType* t : monitor_types()) {
    EXPECT_NE(t->read, nullptr) << t->name;
    MonitorSpec spec;
    spec.type = t->name;
    for (const FieldSpec& f : t->fields) {
      if (f.shape != "number") continue;
      EXPECT_EQ(spec.number(f.key), f.parameters.front().default_value) << t->name << "." << f.key;
      spec.numbers[f.key] = f.parameters.front().hi;
      EXPECT_EQ(spec.number(f.key), f.parameters.front().hi) << t->name << "." << f.key;
    }
    EXPECT_THROW((void)spec.number("not_a_key"), std::invalid_argument) << t->name;
  }
  MonitorSpec probe;
  probe.type = "pressure_probe";
  EXPECT_THROW((void)probe.number("point"), std::invalid_argument);  // a point is geometry, not a number
}
