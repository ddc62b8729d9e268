// A hydrograph release on terrain (release.hydrograph): flow enters across a line on a synthetic slope from
// its uphill side, with the buffer on the bed, and brings in the hydrograph's integral exactly to within one
// row of particles across the opening (the inlet lets particles in one at a time); initial + inflow = current +
// outflow to rounding; no particle leaks or goes under the ground; the flow runs downhill. Bad hydrographs are
// refused naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;
constexpr double kE0 = 500000.0, kN0 = 5000000.0, kCell = 0.05, kSlopeDeg = 20.0;

// A 5 m x 2 m plane at 5 cm cells falling along +x (east) at 20 degrees, UTM 32N.
fs::path write_slope_dem(const fs::path& dir) {
  const int nx = 100, ny = 40;
  const double tilt = std::tan(kSlopeDeg * M_PI / 180);
  const fs::path asc = dir / "slope.asc";
  std::ofstream out(asc);
  out << "ncols " << nx << "\nnrows " << ny << "\nxllcorner " << std::fixed << kE0 << "\nyllcorner " << kN0
      << "\ncellsize " << kCell << "\nNODATA_value -9999\n";
  for (int row = 0; row < ny; ++row)
    for (int i = 0; i < nx; ++i) out << 10.0 - tilt * (i + 0.5) * kCell << (i + 1 < nx ? " " : "\n");
  fs::copy_file(kSource / "scenarios/flume/flume_dem.prj", dir / "slope.prj", fs::copy_options::overwrite_existing);
  return asc;
}

json map_point(double x, double y) { return {kE0 + x, kN0 + y}; }

// The line across the slope at x = 1 m from y = 0.7 to 1.3 m (12 lanes of dp), 0.1 m deep (2 layers).
json slope_scene(const json& hydrograph) {
  json h = hydrograph;
  if (!h.contains("line")) h["line"] = {map_point(1.0, 0.7), map_point(1.0, 1.3)};
  if (!h.contains("depth")) h["depth"] = 0.1;
  return {{"name", "hydrograph-slope"},
          {"dimensions", 3},
          {"dp", kCell},
          {"duration", 0.8},
          {"materials", {{{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0.001}}}},
          {"numerics", {{"boundary_pressure", "extrapolated"}, {"artificial_viscosity", 0.02}}},
          {"terrain", {{"dem", "slope.asc"}, {"corridor", {{"polygon", {map_point(0.1, 0.1), map_point(4.9, 0.1),
                                                                        map_point(4.9, 1.9), map_point(0.1, 1.9)}}}}}},
          {"release", {{"hydrograph", h}, {"material", "water"}}},
          {"output", {{"series_interval", 0.05}}}};
}

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-hydrograph-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
    write_slope_dem(path);
  }
  ~TempDir() { fs::remove_all(path); }
  Scene load(const json& scene) const {
    std::ofstream(path / "scene.json") << scene.dump(2);
    return load_scene(path / "scene.json");
  }
};

}  // namespace

TEST(HydrographRelease, EntersFromTheUphillSideOnTheBedAndBringsInItsIntegral) {
  TempDir tmp;
  // Q rises to 0.12 m3/s at 0.1 s and falls to 0 at 0.5 s: 0.5 x 0.5 s x 0.12 m3/s = 0.03 m3; at the peak 2 m/s over the 0.06 m2
  // opening, supercritical (Froude 2 on 0.1 m), as an inflow must be to impose depth and speed.
  const json scene = slope_scene({{"discharge", {{0, 0}, {0.1, 0.12}, {0.5, 0}}}});
  json with_sections = scene;
  // Downhill, 1.5 m below the line; uphill, behind the buffer (which reaches 0.2 m behind the line).
  with_sections["monitors"] = {{{"type", "section"}, {"name", "below"}, {"line", {map_point(2.5, 0.2), map_point(2.5, 1.8)}}},
                               {{"type", "section"}, {"name", "above"}, {"line", {map_point(0.5, 0.2), map_point(0.5, 1.8)}}}};
  const Scene s = tmp.load(with_sections);
  const auto& setup = std::get<SceneSetup<3>>(s.setup);
  ASSERT_EQ(setup.inlets.size(), 1u);
  const auto& in = setup.inlets[0];
  EXPECT_EQ(in.lanes(), 12u);
  EXPECT_NEAR(in.normal[0], 1.0, 1e-12);  // downhill: east, whichever way the line is drawn
  const double tilt = std::tan(kSlopeDeg * M_PI / 180);
  for (size_t k = 0; k < in.lanes(); ++k) {
    EXPECT_NEAR(in.slope[k], -tilt, 1e-6);  // a plane: the floor is the bed, nothing lifted
    EXPECT_NEAR(in.floor[k], 10.0 - tilt * 1.0, 1e-4);
  }
  // Drawn the other way round, the line lets the flow in the same way (the DEM decides which side is uphill).
  json reversed = scene;
  reversed["release"]["hydrograph"]["line"] = {map_point(1.0, 1.3), map_point(1.0, 0.7)};
  const Scene r = tmp.load(reversed);
  EXPECT_NEAR(std::get<SceneSetup<3>>(r.setup).inlets[0].normal[0], 1.0, 1e-12);

  RunOptions opt;
  opt.out_dir = tmp.path / "run";
  opt.threads = 1;
  const RunSummary sum = run_scene(s, opt);
  ASSERT_EQ(sum.status, "completed") << sum.error;
  const json m = json::parse(sum.metrics_json);
  const double rho = 1000, row = rho * 12 * 2 * std::pow(kCell, 3);  // one row of particles across the opening
  const double inflow = m.at("mass").at("inflow_kg").get<double>();
  EXPECT_NEAR(inflow, rho * 0.03, row);
  EXPECT_EQ(m.at("mass").at("initial_kg").get<double>(), 0.0);
  EXPECT_NEAR(m.at("mass").at("final_kg").get<double>() + m.at("mass").at("outflow_kg").get<double>(), inflow,
              1e-9 * inflow);
  EXPECT_EQ(m.at("leaks").get<int>(), 0);
  // The flow runs downhill: it passes the section below, none goes uphill past the one above.
  std::map<std::string, double> passed;
  for (const auto& mon : m.at("monitors")) passed[mon.at("name").get<std::string>()] = mon.at("volume_passed_m3").get<double>();
  EXPECT_GT(passed["below"], 0.0);
  EXPECT_EQ(passed["above"], 0.0);
}

// The corridor's limit binds a hydrograph release too: what leaves over the corridor's edge is measured against
// what has entered (against the initial mass alone, zero for a hydrograph, the 1 % limit could never bind). The
// corridor here ends 1 m below the line, 3 m short of the DEM's end; the run of the test above passes 2.5 m.
TEST(HydrographRelease, FlowOverTheCorridorsEdgeCountsAgainstWhatHasEntered) {
  TempDir tmp;
  json scene = slope_scene({{"discharge", {{0, 0}, {0.1, 0.12}, {0.5, 0}}}});
  scene["terrain"]["corridor"]["polygon"] = {map_point(0.1, 0.1), map_point(2.0, 0.1), map_point(2.0, 1.9),
                                             map_point(0.1, 1.9)};
  RunOptions opt;
  opt.out_dir = tmp.path / "run";
  opt.threads = 1;
  const RunSummary sum = run_scene(tmp.load(scene), opt);
  EXPECT_EQ(sum.status, "failed");
  EXPECT_NE(sum.error.find("flow left the modelled corridor"), std::string::npos) << sum.error;
}

TEST(HydrographRelease, AVolumeAndDurationIsASurgeOfThatVolume) {
  TempDir tmp;
  // A surge of 0.02 m3 over 0.4 s: the peak 2 V / T = 0.1 m3/s at once, falling to 0 at T.
  const Scene s = tmp.load(slope_scene({{"volume", 0.02}, {"duration", 0.4}}));
  const auto& in = std::get<SceneSetup<3>>(s.setup).inlets[0];
  const double area = 12 * kCell * 2 * kCell;
  EXPECT_NEAR(in.speed_at(0) * area, 0.1, 1e-12);
  EXPECT_NEAR(in.speed_at(0.2) * area, 0.05, 1e-12);
  EXPECT_EQ(in.speed_at(0.4), 0.0);
}

TEST(HydrographRelease, BadHydrographsAreRefusedNamingTheField) {
  TempDir tmp;
  auto refusal = [&](const json& scene) {
    try {
      tmp.load(scene);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal(slope_scene({{"volume", 0.02}})).find("release.hydrograph"), std::string::npos);
  EXPECT_NE(refusal(slope_scene({{"volume", 0.02}, {"duration", 0.4}, {"discharge", 0.1}})).find("release.hydrograph"),
            std::string::npos);
  EXPECT_NE(refusal(slope_scene({{"discharge", 0.1}, {"depth", 0.02}})).find("release.hydrograph.depth"),
            std::string::npos);  // thinner than dp
  // Along the slope instead of across it: the ground either side of it is level.
  EXPECT_NE(refusal(slope_scene({{"discharge", 0.1}, {"line", {map_point(1.0, 1.0), map_point(2.0, 1.0)}}}))
                .find("release.hydrograph.line"),
            std::string::npos);
  json both = slope_scene({{"discharge", 0.1}});
  both["release"]["depth"] = 1.0;
  EXPECT_NE(refusal(both).find("release"), std::string::npos);
}

TEST(HydrographRelease, TheShippedCatchmentSurgeBuildsAtDraft) {
  // scenarios/catchment/jacksboro_hydrograph.json at draft (dp 4 m): the 60 m line makes 15 lanes, one layer of
  // 4 m; the flow enters eastwards (the valley drains east-north-east, the head slope falls east); the floors lie
  // on the 23 degree head slope (the ground under the block release runs 779-821 m); the surge's peak is
  // 2 V / T = 800 m3/s over the 240 m2 opening.
  const fs::path dir = kSource / "scenarios/catchment";
  std::ifstream in(dir / "jacksboro_hydrograph.json");
  json scene = json::parse(in);
  scene["dp"] = 4.0;
  scene["terrain"]["dem"] = (dir / scene["terrain"]["dem"].get<std::string>()).string();  // the copy is elsewhere
  TempDir tmp;
  const Scene s = tmp.load(scene);
  const auto& inlet = std::get<SceneSetup<3>>(s.setup).inlets.at(0);
  EXPECT_EQ(inlet.lanes(), 15u);
  EXPECT_EQ(inlet.layers_in_depth(4.0), 1);
  EXPECT_GT(inlet.normal[0], 0.99);
  for (size_t k = 0; k < inlet.lanes(); ++k) {
    EXPECT_GT(inlet.floor[k], 770.0) << k;
    EXPECT_LT(inlet.floor[k], 830.0) << k;
    EXPECT_LT(inlet.slope[k], 0.0) << k;  // falling along the flow
  }
  EXPECT_NEAR(inlet.speed_at(0) * inlet.opening_area(4.0), 800.0, 1e-9);
  EXPECT_NEAR(inlet.speed_at(60.0), 0.0, 1e-12);
}
