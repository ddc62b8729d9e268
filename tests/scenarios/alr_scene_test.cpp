// The Alr catchment scene (scenarios/catchment/alr.json) is the design basis docs/study.md writes down
// ("Alr catchment: design basis", 2026-12-05): the event, the inflow's place and direction, the dams' crests
// over the thalweg the site rules found. Built at draft (dp 4 m) from the shipped DEM.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kDir = fs::path(RUNOUT_SOURCE_DIR) / "scenarios" / "catchment";

Scene load_at_draft() {
  std::ifstream in(kDir / "alr.json");
  json scene = json::parse(in);
  scene["dp"] = 4.0;
  scene["terrain"]["dem"] = (kDir / scene["terrain"]["dem"].get<std::string>()).string();
  const fs::path tmp = fs::temp_directory_path() / "runout-alr-scene";
  fs::create_directories(tmp);
  std::ofstream(tmp / "scene.json") << scene.dump(2);
  Scene s = load_scene(tmp / "scene.json");
  fs::remove_all(tmp);
  return s;
}

}  // namespace

TEST(AlrScene, TheEventAndTheInflowAreTheBasis) {
  const Scene s = load_at_draft();
  const auto& inlet = std::get<SceneSetup<3>>(s.setup).inlets.at(0);
  // 30 000 m3 as a triangular surge over 600 s: 100 m3/s at t = 0, nothing at 600 s.
  EXPECT_NEAR(inlet.speed_at(0) * inlet.opening_area(4.0), 100.0, 1e-9);
  EXPECT_NEAR(inlet.speed_at(600.0), 0.0, 1e-12);
  EXPECT_EQ(inlet.layers_in_depth(4.0), 1);
  EXPECT_LT(inlet.normal[1], -0.99);  // the channel runs south
  // The lanes' floors lie on the channel's bed at the inflow (thalweg 1 648.9 m; the banks 4 m higher).
  for (size_t k = 0; k < inlet.lanes(); ++k) {
    EXPECT_GT(inlet.floor[k], 1640.0) << k;
    EXPECT_LT(inlet.floor[k], 1660.0) << k;
  }
}

TEST(AlrScene, TheDamsStand8mOverTheThalwegTheSiteRulesFound) {
  const Scene s = load_at_draft();
  ASSERT_TRUE(s.terrain);
  // Thalweg at each site (docs/study.md: the lowest 5 m cell within 25 m of the path); the crest is the lowest
  // ground on the axis + 8 m, which the built DEM (bilinear at 4 m) finds within a cell's relief of it.
  const std::map<std::string, double> thalweg{{"Dam1", 1492.5}, {"Dam2", 1326.9}, {"Dam3", 1064.6}};
  ASSERT_EQ(s.terrain->structures.size(), 3u);
  for (const auto& st : s.terrain->structures) {
    SCOPED_TRACE(st.name);
    ASSERT_TRUE(thalweg.count(st.name));
    EXPECT_NEAR(st.crest_elevation, thalweg.at(st.name) + 8.0, 2.0);
    EXPECT_GT(st.storage_capacity, 0.0);
    EXPECT_LT(st.flow_normal[1], -0.9);  // the flow pushes them south
  }
}

TEST(AlrScene, TheSweepIsTheFactorialOfTheThreeDams) {
  const Sweep sw = load_sweep(kDir / "alr_g0_g7.json");
  ASSERT_EQ(sw.variants.size(), 8u);
  EXPECT_EQ(sw.variants.front().name, "G0");
  EXPECT_TRUE(sw.variants.front().structures.empty());
  EXPECT_EQ(sw.variants.back().structures.size(), 3u);
}
