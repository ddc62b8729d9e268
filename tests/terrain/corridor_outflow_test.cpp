// Flow that crosses the corridor's edge leaves the model: it is removed and counted as corridor outflow, the
// mass balance stays exact, and the run fails only when more of the release than terrain.corridor.max_outflow
// has gone that way (the corridor is too narrow for the flow). A plane falling diagonally (29.5 degrees
// towards +x +y) with a corridor polygon that is a strip along x: the flow slides out through the strip's
// north side, which is not on the DEM's edge.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

constexpr double kE0 = 500000.0, kN0 = 4000000.0;  // UTM 16N, the DEM's south-west corner
constexpr double kLx = 80.0, kLy = 50.0;
constexpr double kStripY1 = 32.0;  // the corridor strip's north side (local to the DEM)

double plane_z(double x, double y) { return 60.0 - 0.4 * x - 0.4 * y; }

struct Fixture {
  fs::path dir;
  Fixture() {
    dir = fs::temp_directory_path() /
          ("runout-corridor-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    terrain::Grid g(static_cast<int>(kLx), static_cast<int>(kLy), kE0, kN0 + kLy, 1.0, 1.0,
                    terrain::crs_wkt_from("EPSG:32616"));
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) g.at(i, j) = static_cast<float>(plane_z(g.cx(i) - kE0, g.cy(j) - kN0));
    terrain::write_geotiff((dir / "plane.tif").string(), g);
  }
  ~Fixture() { fs::remove_all(dir); }

  json scene(std::optional<double> max_outflow) const {
    auto at = [](double x, double y) { return json::array({kE0 + x, kN0 + y}); };
    json corridor = {{"polygon", json::array({at(5, 18), at(70, 18), at(70, kStripY1), at(5, kStripY1)})}};
    if (max_outflow) corridor["max_outflow"] = *max_outflow;
    return {{"name", "corridor-outflow"},
            {"dimensions", 3},
            {"dp", 0.5},
            {"duration", 3.0},
            {"materials", json::array({{{"name", "debris"},
                                        {"rheology", "friction-hbp"},
                                        {"density", 2000},
                                        {"viscosity", 1.0},
                                        {"flow_index", 1.0},
                                        {"regularisation", 100},
                                        {"friction_angle", 10},
                                        {"cohesion", 0}}})},
            {"terrain", {{"dem", (dir / "plane.tif").string()}, {"corridor", corridor}}},
            {"release", {{"polygon", json::array({at(10, 22), at(14, 22), at(14, 26), at(10, 26)})},
                         {"depth", 1.0},
                         {"material", "debris"}}},
            {"numerics", {{"speed_of_sound", 150}}},
            {"output", {{"series_interval", 0.1}}}};
  }

  json run(const json& j, const std::string& label) const {
    const Scene scene = parse_scene(j.dump(), dir);
    RunOptions opt;
    opt.out_dir = dir / label;
    run_scene(scene, opt);
    std::ifstream in(opt.out_dir / "metrics.json");
    std::stringstream s;
    s << in.rdbuf();
    return json::parse(s.str());
  }
};

}  // namespace

TEST(CorridorOutflow, FlowPastTheCorridorEdgeIsRemovedAndCountedWithTheMassExact) {
  const Fixture fx;
  const json m = fx.run(fx.scene(1.0), "allowed");
  ASSERT_EQ(m["status"], "completed") << m.dump(2);
  EXPECT_EQ(m["leaks"], 0);
  const json& out = m["terrain"]["corridor_outflow"];
  const long n0 = m["particles"]["fluid_initial"], n1 = m["particles"]["fluid_final"];
  const long gone = out["particles"];
  // The flow slides diagonally off the strip: a good part of it has left within 3 s.
  EXPECT_GT(gone, n0 / 4) << out.dump();
  EXPECT_EQ(n1 + gone, n0);  // every particle is either in the model or counted as corridor outflow
  // Mass exact, and all the outflow went through the corridor's edge (the DEM's edge is far).
  const double m0 = m["mass"]["initial_kg"];
  EXPECT_LT(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
  EXPECT_NEAR(m["mass"]["outflow_kg"].get<double>(), out["mass_kg"].get<double>(), 1e-9 * m0);
  EXPECT_NEAR(out["fraction"].get<double>(), out["mass_kg"].get<double>() / m0, 1e-12);
  // It left through the strip's north (downhill) side, within the check's travel of it.
  const double north = out["first_point"][1].get<double>() - kN0;
  EXPECT_GT(north, kStripY1 - 1.0) << out.dump();
  EXPECT_LT(north, kStripY1 + 2.0) << out.dump();
  bool warned = false;
  for (const auto& w : m["warnings"]) warned = warned || w.get<std::string>().find("left the modelled corridor") != std::string::npos;
  EXPECT_TRUE(warned) << m["warnings"].dump();
}

TEST(CorridorOutflow, MoreThanTheLimitFailsTheRunNamingTheField) {
  const Fixture fx;
  const json m = fx.run(fx.scene(std::nullopt), "default");  // default limit: 1 % of the release
  ASSERT_EQ(m["status"], "failed") << m.dump(2);
  EXPECT_EQ(m["leaks"], 0);  // not a leak: nothing went under the ground
  const std::string error = m["error"];
  EXPECT_NE(error.find("terrain.corridor.max_outflow = 0.01"), std::string::npos) << error;
  EXPECT_NE(error.find("widen terrain.corridor"), std::string::npos) << error;
  EXPECT_GT(m["terrain"]["corridor_outflow"]["fraction"].get<double>(), 0.01);
}

TEST(CorridorOutflow, LimitOutsideZeroToOneIsRefused) {
  const Fixture fx;
  for (double bad : {-0.1, 1.5}) {
    try {
      parse_scene(fx.scene(bad).dump(), fx.dir);
      ADD_FAILURE() << "accepted max_outflow " << bad;
    } catch (const SceneError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("terrain.corridor.max_outflow"), std::string::npos) << what;
      EXPECT_NE(what.find("[0, 1]"), std::string::npos) << what;
    }
  }
}
