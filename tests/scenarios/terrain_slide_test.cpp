// Debris sliding down a terrain plane: a synthetic DEM falling at 30 degrees, gravity vertical, the bed laid
// from the DEM near the flow. A friction-HBP row (one particle along the slope) and a one-particle sheet have
// no resolved pressure of their own; the bed's Coulomb friction carries them, so their mean speed grows at the
// rigid slide's rate a = g (sin(theta) - cos(theta) sin(phi)) (tests/engine/basal_friction_test.cpp has the
// same on a plane of wall particles with gravity tilted). Measured 2026-12-02 at 5 s, rigid 10.0 m/s: with
// the extrapolated wall pressure's hydrostatic term along all of g (before), the row 2.35 m/s and the sheet
// 8.57 m/s (the wall particles downslope of the flow's edges pushed it back uphill); with the term along the
// bed's normal, 10.09 and 10.06 m/s. Tolerance 10 %, ThinSheet's: the slip regularisation and the lattice's
// uneven push; a sheet with edges also spreads, which adds to its mean speed.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;
constexpr double kE0 = 500000.0, kN0 = 5000000.0, kDp = 2.0, kSlopeDeg = 30.0, kPhiDeg = 20.0, kG = 9.81;
constexpr double kLength = 160.0, kWidth = 40.0, kDuration = 5.0;

json map_point(double x, double y) { return {kE0 + x, kN0 + y}; }

// The plane at dp cells, falling along +x (east), UTM 32N.
void write_plane_dem(const fs::path& dir) {
  const int nx = static_cast<int>(kLength / kDp), ny = static_cast<int>(kWidth / kDp);
  const double tilt = std::tan(kSlopeDeg * M_PI / 180);
  std::ofstream out(dir / "plane.asc");
  out << "ncols " << nx << "\nnrows " << ny << "\nxllcorner " << std::fixed << kE0 << "\nyllcorner " << kN0
      << "\ncellsize " << kDp << "\nNODATA_value -9999\n";
  for (int row = 0; row < ny; ++row)
    for (int i = 0; i < nx; ++i) out << 200.0 - tilt * (i + 0.5) * kDp << (i + 1 < nx ? " " : "\n");
  fs::copy_file(kSource / "scenarios/flume/flume_dem.prj", dir / "plane.prj", fs::copy_options::overwrite_existing);
}

// Mean speed sqrt(2 KE / m) after kDuration of a release `along` m long (down the slope) and 20 m wide, one
// particle deep.
double slide_speed(double along, const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("runout-terrain-slide-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_plane_dem(dir);
  const json scene = {
      {"name", "terrain-slide"},
      {"dimensions", 3},
      {"dp", kDp},
      {"duration", kDuration},
      {"materials",
       {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0}, {"flow_index", 1.05},
         {"regularisation", 100}, {"friction_angle", kPhiDeg}, {"cohesion", 0}}}},
      {"numerics", {{"boundary_pressure", "extrapolated"}, {"speed_of_sound", 60}}},
      {"terrain", {{"dem", "plane.asc"}, {"corridor", {{"polygon", {map_point(1, 1), map_point(kLength - 1, 1),
                                                                    map_point(kLength - 1, kWidth - 1),
                                                                    map_point(1, kWidth - 1)}}}}}},
      {"release", {{"polygon", {map_point(10, 10), map_point(10 + along, 10), map_point(10 + along, 30),
                                map_point(10, 30)}},
                   {"depth", kDp},
                   {"material", "debris"}}},
      {"output", {{"series_interval", 0.5}}}};
  std::ofstream(dir / "scene.json") << scene.dump(2);
  RunOptions opt;
  opt.out_dir = dir / "out";
  const RunSummary r = run_scene(load_scene(dir / "scene.json"), opt);
  EXPECT_EQ(r.status, "completed") << name;
  const json m = json::parse(r.metrics_json);
  fs::remove_all(dir);
  return std::sqrt(2.0 * m["energy"]["kinetic_final_j"].get<double>() / m["mass"]["initial_kg"].get<double>());
}

double rigid_slide_speed() {
  const double theta = kSlopeDeg * M_PI / 180, phi = kPhiDeg * M_PI / 180;
  return kG * (std::sin(theta) - std::cos(theta) * std::sin(phi)) * kDuration;
}

}  // namespace

TEST(TerrainSlide, ARowSlidesAtTheCoulombRate) {
  const double rigid = rigid_slide_speed();
  EXPECT_NEAR(slide_speed(kDp, "row"), rigid, 0.10 * rigid);
}

TEST(TerrainSlide, AOneParticleSheetSlidesAtTheCoulombRate) {
  const double rigid = rigid_slide_speed();
  EXPECT_NEAR(slide_speed(20.0, "sheet"), rigid, 0.10 * rigid);
}
