// The point probes on terrain: still water in a square pit of a synthetic DEM, the probes given in map
// coordinates. A pressure probe at a height above
// the bed reads rho0 g (H - z), a depth gauge in the pit the water's depth, one on the dry rim exactly 0, and one
// along a line across the pit its depth in the pit.
//
// Tolerances as in tests/engine/probes_test.cpp, from the model: pressure within 3 % of rho0 g (H - z) (the weakly
// compressible model's hydrostatic error, docs/validation.md section 1) plus rho0 g delta (the column sinks by
// delta = g H^2 / (2 c0^2) under its own weight), for probes whose kernel support lies in the water (2h from
// the bed and the surface); depth within dp (the level where the interpolated fluid fraction is 1/2 moves by a
// fraction of dp with the particles' arrangement; the interface is smeared over about h). The probe at the
// default height, h above the bed, has its support cut by the bed h under it: the Shepard mean of the linear
// pressure field is then taken over particles centred higher than the point, by less than h, hence rho0 g h more.
//
// The solver is stepped here without the run's terrain check: that check flags a particle as under the ground
// when it is more than dp under the bilinear interpolation of the bed columns, and in a concave corner of a
// vertical DEM step (this pit's) the interpolation rises a tenth of dp for each millimetre towards the corner: at
// c0 = 20 m/s a corner particle of the bottom layer, 1.4 mm from its start, was flagged (t = 0.045 s), though it
// was 11 mm over the pit's floor. The outputs of a whole run are checked in probe_scenes_test.cpp.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "runout/engine/monitors.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-probes-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// A 1 m x 1 m DEM at 2.5 cm cells (UTM 32N, lower-left corner at (500000, 5000000)), level at 10 m but for a pit
// 0.3 m deep over x, y in [0.3, 0.7] m: cell edges, so the bed's dp columns (dp = the cell) hold it exactly.
constexpr double kE0 = 500000.0, kN0 = 5000000.0, kCell = 0.025, kTop = 10.0, kPitFloor = 9.7;

void write_pit_dem(const fs::path& asc) {
  const int n = 40;
  std::ofstream out(asc);
  out << "ncols " << n << "\nnrows " << n << "\nxllcorner " << std::fixed << kE0 << "\nyllcorner " << kN0
      << "\ncellsize " << kCell << "\nNODATA_value -9999\n";
  for (int row = 0; row < n; ++row) {
    const int j = n - 1 - row;  // rows run north to south
    for (int i = 0; i < n; ++i) out << (i >= 12 && i < 28 && j >= 12 && j < 28 ? kPitFloor : kTop) << (i + 1 < n ? " " : "\n");
  }
  fs::copy_file(kSource / "scenarios/flume/flume_dem.prj", fs::path(asc).replace_extension(".prj"));
}

json map_point(double x, double y) { return {kE0 + x, kN0 + y}; }
json map_point(double x, double y, double z) { return {kE0 + x, kN0 + y, z}; }

// Steps the scene to its end; each monitor's columns averaged over the samples (every 10 steps) of the last
// `window` seconds, and its summary at the end.
struct Readings {
  std::vector<std::vector<double>> mean;
  std::vector<std::vector<std::pair<std::string, real>>> summary;
  double wall = 0;
};

Readings run_and_sample(const Scene& s, real window) {
  Solver<3> solver(std::get<SceneSetup<3>>(s.setup));
  std::vector<std::unique_ptr<Monitor<3>>> monitors;
  for (const auto& spec : s.monitors) monitors.push_back(make_monitor<3>(spec, solver));
  Readings r;
  r.mean.resize(monitors.size());
  for (size_t k = 0; k < monitors.size(); ++k) r.mean[k].assign(monitors[k]->columns().size(), 0.0);
  int n = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (solver.time() < s.duration) {
    solver.step();
    if (solver.steps() % 10 != 0 || solver.time() < s.duration - window) continue;
    for (size_t k = 0; k < monitors.size(); ++k) {
      const auto row = monitors[k]->sample(solver);
      for (size_t c = 0; c < row.size(); ++c) r.mean[k][c] += row[c];
    }
    ++n;
  }
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GT(n, 10);
  for (auto& m : r.mean)
    for (auto& v : m) v /= std::max(n, 1);
  for (const auto& m : monitors) r.summary.push_back(m->summary());
  return r;
}

real summary_value(const std::vector<std::pair<std::string, real>>& sum, const std::string& key) {
  for (const auto& [k, v] : sum)
    if (k == key) return v;
  ADD_FAILURE() << "no summary value " << key;
  return 0;
}

}  // namespace

TEST(ProbesOnTerrain, StillWaterInAPitReadsHydrostaticPressureAndItsDepth) {
  TempDir tmp;
  write_pit_dem(tmp.path / "pit.asc");
  const double H = 0.2;  // release depth: 8 layers of dp
  json scene = {
      {"name", "pit"},
      {"dimensions", 3},
      {"dp", kCell},
      {"duration", 0.8},
      {"materials", {{{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0}}}},
      // c0 = 20 m/s, 14 sqrt(g H) (a plain scene's default would be 10 sqrt(g 0.275 m) = 16 m/s; the terrain
      // default, from the energy line over the reach, 31 m/s and half as many steps again). Artificial viscosity
      // damps the start-up waves, as in the shipped hydrostatic tank.
      {"numerics", {{"artificial_viscosity", 1.0}, {"speed_of_sound", 20.0}}},
      {"terrain", {{"dem", "pit.asc"}, {"corridor", {{"polygon", {map_point(0.1, 0.1), map_point(0.9, 0.1),
                                                                  map_point(0.9, 0.9), map_point(0.1, 0.9)}}}}}},
      {"release", {{"polygon", {map_point(0.3, 0.3), map_point(0.7, 0.3), map_point(0.7, 0.7), map_point(0.3, 0.7)}},
                   {"depth", H},
                   {"material", "water"}}},
      {"monitors",
       {{{"type", "pressure_probe"}, {"name", "low"}, {"point", map_point(0.5, 0.5, 0.075)}},
        {{"type", "pressure_probe"}, {"name", "high"}, {"point", map_point(0.5, 0.5, 0.125)}},
        {{"type", "pressure_probe"}, {"name", "default"}, {"point", map_point(0.5, 0.5)}},
        {{"type", "pressure_probe"}, {"name", "air"}, {"point", map_point(0.5, 0.5, 0.3)}},
        {{"type", "depth_gauge"}, {"name", "centre"}, {"point", map_point(0.5, 0.5)}},
        {{"type", "depth_gauge"}, {"name", "rim"}, {"point", map_point(0.2, 0.2)}},
        {{"type", "depth_gauge"}, {"name", "across"}, {"line", {map_point(0.15, 0.5), map_point(0.85, 0.5)}}}}}};
  std::ofstream(tmp.path / "pit.json") << scene.dump(2);
  const Scene s = load_scene(tmp.path / "pit.json");
  const auto& setup = std::get<SceneSetup<3>>(s.setup);
  const double h = setup.config.smoothing_length, c0 = setup.config.speed_of_sound;
  // The points in the run's frame: map coordinates less the local origin, heights from the bed (the DEM's
  // elevations are single precision).
  ASSERT_EQ(s.monitors.size(), 7u);
  EXPECT_NEAR(s.monitors[0].probe_points[0][2], kPitFloor + 0.075, 1e-5);
  EXPECT_NEAR(s.monitors[2].probe_points[0][2], kPitFloor + h, 1e-5);
  EXPECT_NEAR(s.monitors[4].probe_points[0][2], kPitFloor, 1e-5);
  EXPECT_NEAR(s.monitors[5].probe_points[0][2], kTop, 1e-5);
  EXPECT_EQ(s.monitors[6].probe_points.size(), 29u);  // 0.7 m at dp: 28 intervals
  double top = -1e300;
  for (size_t i = 0; i < setup.fluid.size(); ++i) top = std::max(top, setup.fluid.pos[2][i] + 0.5 * kCell);
  ASSERT_NEAR(top, kPitFloor + H, 1e-5);

  const Readings r = run_and_sample(s, 0.25);
  const double delta = 9.81 * H * H / (2 * c0 * c0);
  auto check_pressure = [&](size_t k, double z, double extra) {
    const auto& m = r.mean[k];
    const double ref = 1000 * 9.81 * (H - z), tol = 0.03 * ref + 1000 * 9.81 * (delta + extra);
    std::printf("  terrain probe '%s' %.4f m above the bed: %.1f Pa against %.1f Pa (%+.2f %%; tolerance %.1f Pa), "
                "kernel sum %.3f\n",
                s.monitors[k].name.c_str(), z, m[0], ref, 100 * (m[0] - ref) / ref, tol, m[1]);
    EXPECT_NEAR(m[0], ref, tol) << s.monitors[k].name;
    EXPECT_EQ(m[2], 1.0) << s.monitors[k].name << ": wet at every sample";
  };
  check_pressure(0, 0.075, 0.0);
  check_pressure(1, 0.125, 0.0);
  check_pressure(2, h, h);
  EXPECT_EQ(r.mean[3][0], 0.0);  // 0.1 m over the surface, beyond the kernel's reach 2h = 0.075 m
  EXPECT_EQ(r.mean[3][2], 0.0);
  EXPECT_EQ(summary_value(r.summary[3], "wet_fraction"), 0.0);

  const auto &centre = r.mean[4], &rim = r.mean[5], &across = r.mean[6];
  std::printf("  terrain depth gauge: %.4f m in the pit (surface %.4f m), %.2e m on the dry rim, %.4f m the deepest "
              "station across at %.3f m along; against H = %.3f m (tolerance dp = %.3f m); c0 %.1f m/s, %.1f s wall\n",
              centre[0], centre[1], rim[0], across[0], across[2], H, kCell, c0, r.wall);
  EXPECT_NEAR(centre[0], H, kCell);
  EXPECT_NEAR(centre[1], kPitFloor + H, kCell);
  EXPECT_EQ(rim[0], 0.0);  // dry ground, no particle within reach: the floor's own share is 1/2
  EXPECT_EQ(summary_value(r.summary[5], "max_depth_m"), 0.0);
  EXPECT_NEAR(across[0], H, kCell);
  EXPECT_GT(across[2], 0.15);  // in the pit: 0.15 to 0.55 m along the line
  EXPECT_LT(across[2], 0.55);
  EXPECT_NEAR(summary_value(r.summary[6], "final_depth_m"), H, kCell);
}
