// Validation (issue 41, part 3): a granular mass stopping on terrain against the Coulomb energy line.
//
// A block sliding with Coulomb friction mu loses mu g cos(theta) ds of energy per unit mass over a path element
// ds at slope theta, i.e. mu g dx per horizontal dx, whatever the slope: it stops where its drop equals mu times
// its horizontal travel (Heim's energy line, the basis of the travel-angle rule; AvaFrame's com1DFA checks its
// centre of mass against the same line in its energy-line test). The engine's bed friction for friction-HBP is
// mu = sin(phi) (docs/design.md, "Thin sheets, walls and basal friction"). Left out by the line: the
// centripetal load on a concave bend (more friction: the mass stops short), the material's internal
// dissipation (short), and the spreading of the mass (its centre of mass is not a block's).
//
// Scene A (declared before its first run, 2026-12-05): a synthetic DEM falling east at 30 deg for 60 m, a
// concave circular bend of radius 120 m easing to 10 deg, then 10 deg to 240 m; 80 m wide; 1 m cells (UTM 32N).
// A block 20 m along the slope, 12 m wide and 2 m deep released on the face (x 10-30 m), the studies' material
// (the catchment scenes' friction-HBP: phi 20 deg, c 0, 1 Pa s, n 1.05, m 100 s), dp 1 m, the granular defaults
// a terrain scene gets, the catchment scenes' rest test (95 % of the flow under 0.5 m/s for 2 s) ending it, at
// most 60 s. With mu = sin 20 deg = 0.342 (18.9 deg) the line meets the 10 deg runout. The aim, declared: the
// centre of mass's horizontal travel within 10 % of the line's reach (where the line from the start, falling
// at mu, meets the ground plus the centre's starting height over it).
// Measured (2026-12-05, dp 1 m, one thread, 33 s): travel 125.9 m against the line's 141.2 m (-10.8 %,
// travel angle 20.3 against 18.9 deg): a known failure (tests/CMakeLists.txt, WILL_FAIL), kept as declared.
//
// What the line leaves out is a term of the same rigid block, not a property of the code: on a bend of
// curvature k the bed carries g cos(theta) + v^2 k, so the block loses mu v^2 dtheta more over the bend (at
// 13.6 m/s entering a 20 deg bend, 2.25 m of head: 13.6 m of the 10 deg runout). The block's own stopping point
// with that term (integrated along the profile below, no parameter) is 126.9 m for scene A: that comparison was
// made after A's run. So it is asserted on a scene declared before its run (2026-12-05), where the two
// predictions lie far apart: scene B, a 35 deg face 50 m long, a bend of radius 60 m to 10 deg, the release on
// x 5-25 m, all else as A: line 145.1 m, block 122.6 m. Asserted on A and B: the centre of mass's travel within
// 10 % of the block's (the tolerance), no leak, at rest within 60 s.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "bend_profile.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;
constexpr double kE0 = 500000.0, kN0 = 5000000.0;  // the DEM's south-west corner
constexpr double kLength = 240.0, kWidth = 80.0, kCell = 1.0, kPhiDeg = 20.0, kG = 9.81;
constexpr double kDeg = M_PI / 180;

using Profile = runout_test::BendProfile;
const Profile& kSceneA = runout_test::kBendA;
const Profile& kSceneB = runout_test::kBendB;

void write_dem(const Profile& p, const fs::path& dir) {
  const int nx = static_cast<int>(kLength / kCell), ny = static_cast<int>(kWidth / kCell);
  std::ofstream out(dir / "bend.asc");
  out << "ncols " << nx << "\nnrows " << ny << "\nxllcorner " << std::fixed << kE0 << "\nyllcorner " << kN0
      << "\ncellsize " << kCell << "\nNODATA_value -9999\n";
  out.precision(4);
  for (int row = 0; row < ny; ++row)
    for (int i = 0; i < nx; ++i) out << p.ground((i + 0.5) * kCell) << (i + 1 < nx ? " " : "\n");
  fs::copy_file(kSource / "scenarios/flume/flume_dem.prj", dir / "bend.prj", fs::copy_options::overwrite_existing);
}

json map_point(double x, double y) { return {kE0 + x, kN0 + y}; }

json scene_of(const Profile& p, double dp) {
  const double y0 = 0.5 * kWidth - 6, y1 = 0.5 * kWidth + 6, x0 = p.release_from, x1 = p.release_to;
  return {{"name", std::string("energy-line-") + p.name},
          {"dimensions", 3},
          {"dp", dp},
          {"duration", 60.0},
          {"materials",
           {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0},
             {"flow_index", 1.05}, {"regularisation", 100}, {"friction_angle", kPhiDeg}, {"cohesion", 0}}}},
          {"terrain", {{"dem", "bend.asc"},
                       {"corridor", {{"polygon", {map_point(1, 1), map_point(kLength - 1, 1),
                                                  map_point(kLength - 1, kWidth - 1), map_point(1, kWidth - 1)}}}}}},
          {"release", {{"polygon", {map_point(x0, y0), map_point(x1, y0), map_point(x1, y1), map_point(x0, y1)}},
                       {"depth", 2.0},
                       {"material", "debris"}}},
          {"output", {{"series_interval", 0.5}, {"rest_speed", 0.5}, {"rest_quantile", 0.95}, {"rest_time", 2.0}}}};
}

// The line's reach from a start at (x0, z0): the horizontal travel at which z0 - mu L falls to the ground plus
// the start's height over it; by bisection (the gap shrinks once the ground eases below the line's angle).
double line_reach(const Profile& p, double x0, double z0, double mu) {
  const double h = z0 - p.ground(x0);
  auto gap = [&](double L) { return z0 - mu * L - (p.ground(x0 + L) + h); };
  double lo = 1, hi = kLength - x0 - 1;
  if (gap(hi) > 0) return hi;  // beyond the DEM
  for (int i = 0; i < 100; ++i) (gap(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

double block_reach(const Profile& p, double x0, double mu) { return runout_test::block_reach(p, x0, mu, kLength, kG); }

struct Stop {
  RunSummary run;
  json metrics;
  double x0 = 0, z0 = 0, travel = 0, line = 0, block = 0;
};

Stop run_profile(const Profile& p) {
  double dp = 1.0;
  if (const char* e = std::getenv("RUNOUT_ENERGY_LINE_DP")) dp = std::stod(e);
  const fs::path dir = fs::path(RUNOUT_BINARY_DIR) / "validation" / (std::string("energy_line_") + p.name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_dem(p, dir);
  std::ofstream(dir / "scene.json") << scene_of(p, dp).dump(2);
  RunOptions opt;
  opt.out_dir = dir / "out";
  Stop s;
  s.run = run_scene(load_scene(dir / "scene.json"), opt);
  if (s.run.status != "completed") return s;
  s.metrics = json::parse(s.run.metrics_json);
  const json& com = s.metrics["centre_of_mass"];
  if (com.is_null()) return s;
  const double mu = std::sin(kPhiDeg * kDeg);
  s.x0 = com["start_map"][0].get<double>() - kE0;
  s.z0 = com["start_map"][2].get<double>();
  s.travel = com["horizontal_travel_m"].get<double>();
  s.line = line_reach(p, s.x0, s.z0, mu);
  s.block = block_reach(p, s.x0, mu);
  std::printf("  scene %s, dp %.2f m: %ld steps, %.0f s wall, ended at %.1f s%s, leaks %ld\n", p.name, dp, s.run.steps,
              s.run.wall_seconds, s.run.simulated_time, s.run.ended_at_rest ? " at rest" : " (not at rest)",
              s.metrics["leaks"].get<long>());
  std::printf("  centre of mass: x %.1f m, travel %.1f m, drop %.1f m, travel angle %.2f deg\n", s.x0, s.travel,
              com["drop_m"].get<double>(), com["travel_angle_deg"].get<double>());
  std::printf("  energy line (mu = sin phi = %.3f, %.2f deg): reach %.1f m (travel/reach %.3f); block with the "
              "bend's load: %.1f m (%.3f)\n", mu, std::atan(mu) / kDeg, s.line, s.travel / s.line, s.block,
              s.travel / s.block);
  return s;
}

}  // namespace

// Known failure (tests/CMakeLists.txt, WILL_FAIL): the aim as first declared, scene A against the plain line.
TEST(EnergyLine, DISABLED_CentreOfMassStopsWithinTenPercentOfTheEnergyLinesReach) {
  const Stop s = run_profile(kSceneA);
  ASSERT_EQ(s.run.status, "completed") << s.run.error;
  ASSERT_FALSE(s.metrics["centre_of_mass"].is_null());
  EXPECT_NEAR(s.travel, s.line, 0.10 * s.line) << "centre of mass's travel against the energy line's reach";
}

TEST(EnergyLine, CentreOfMassStopsWhereACoulombBlockWithTheBendsLoadStops) {
  for (const Profile& p : {kSceneA, kSceneB}) {
    SCOPED_TRACE(p.name);
    const Stop s = run_profile(p);
    ASSERT_EQ(s.run.status, "completed") << s.run.error;
    ASSERT_FALSE(s.metrics["centre_of_mass"].is_null());
    EXPECT_EQ(s.metrics["leaks"].get<long>(), 0);
    EXPECT_TRUE(s.run.ended_at_rest) << "the run did not end at rest within its 60 s";
    EXPECT_NEAR(s.travel, s.block, 0.10 * s.block) << "centre of mass's travel against the block's";
  }
}
