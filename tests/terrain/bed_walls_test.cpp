// The bed's wall particles laid near the flow (terrain.walls = "near_flow", the default) against the whole bed
// laid at the start ("all"): on a plane a debris release slides down, the two runs give the same metrics and
// series to the bit (one thread), with no leak and the mass exact, while a small part of the bed is alive.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/raster.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

constexpr double kE0 = 500000.0, kN0 = 4000000.0;  // UTM 16N, the DEM's south-west corner

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Plane {
  fs::path dir;
  Plane() {
    dir = fs::temp_directory_path() /
          ("runout-bed-walls-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    terrain::Grid g(80, 30, kE0, kN0 + 30, 1.0, 1.0, terrain::crs_wkt_from("EPSG:32616"));
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) g.at(i, j) = static_cast<float>(60.0 - 0.4 * (g.cx(i) - kE0));
    terrain::write_geotiff((dir / "plane.tif").string(), g);
  }
  ~Plane() { fs::remove_all(dir); }

  json scene(const std::string& walls) const {
    auto at = [](double x, double y) { return json::array({kE0 + x, kN0 + y}); };
    return {{"name", "bed-walls"},
            {"dimensions", 3},
            {"dp", 0.5},
            {"duration", 2.0},
            {"materials", json::array({{{"name", "debris"},
                                        {"rheology", "friction-hbp"},
                                        {"density", 2000},
                                        {"viscosity", 1.0},
                                        {"friction_angle", 10},
                                        {"cohesion", 0}}})},
            {"terrain", {{"dem", (dir / "plane.tif").string()}, {"walls", walls}}},
            {"release", {{"polygon", json::array({at(8, 12), at(12, 12), at(12, 18), at(8, 18)})},
                         {"depth", 1.0},
                         {"material", "debris"}}},
            {"numerics", {{"speed_of_sound", 150}, {"boundary_pressure", "extrapolated"}}},
            {"output", {{"series_interval", 0.1}}}};
  }

  json run(const std::string& walls) const {
    const Scene parsed = parse_scene(scene(walls).dump(), dir);
    RunOptions opt;
    opt.out_dir = dir / walls;
    opt.threads = 1;
    run_scene(parsed, opt);
    return json::parse(read(opt.out_dir / "metrics.json"));
  }
};

}  // namespace

TEST(BedWalls, NearTheFlowGivesTheRunOfTheWholeBedWithAFractionOfItsParticles) {
  const Plane plane;
  const int threads = omp_get_max_threads();
  json near = plane.run("near_flow"), whole = plane.run("all");
  omp_set_num_threads(threads);
  ASSERT_EQ(near["status"], "completed") << near.dump(2);
  EXPECT_EQ(near["leaks"], 0);
  EXPECT_LT(std::abs(near["mass"]["relative_error"].get<double>()), 1e-12);
  // It moved: a Coulomb block on this 21.8 deg plane (friction 10 deg) slides g (sin - tan 10 deg cos) t^2 / 2
  // = 4.1 m in 2 s; the flow's front goes at least half that (not a run that stood still).
  EXPECT_GT(near["terrain"]["inundation"]["runout_m"].get<double>(), 2.0) << near["terrain"].dump(2);

  const long fluid = near["particles"]["fluid_initial"], described = near["particles"]["boundary"];
  const long peak = near["particles"]["boundary_peak"];
  EXPECT_EQ(described, whole["particles"]["boundary"].get<long>());
  EXPECT_EQ(whole["particles"]["boundary_peak"].get<long>(), described);
  // The flow covers a few of the plane's 2 400 m2 (the release is 24 m2): at most a quarter of the bed alive.
  EXPECT_LT(peak, described / 4) << "peak " << peak << " of " << described << " for " << fluid << " flow particles";
  EXPECT_GT(near["particles"]["wall_rebuilds"].get<long>(), 1);

  // Everything else to the bit: the same bed particles meet the flow in the same order.
  // The cost features say how the bed is laid: near the flow it is all `bed`, laid whole all fixed walls.
  EXPECT_EQ(near["cost_features"]["bed"].get<double>(), whole["cost_features"]["boundary_fixed"].get<double>());
  for (json* m : {&near, &whole}) {
    for (const char* k : {"wall_time_s", "particle_steps_per_s"}) m->erase(k);
    (*m)["particles"].erase("boundary_peak");
    (*m)["particles"].erase("wall_rebuilds");
    m->erase("neighbour_list_builds");  // near the flow, each change of the walls alive scans them again
    (*m)["cost_features"].erase("bed");
    (*m)["cost_features"].erase("boundary_fixed");
  }
  EXPECT_EQ(near.dump(2), whole.dump(2));
  for (const auto& e : fs::directory_iterator(plane.dir / "all" / "series")) {
    if (e.path().filename() == "run.csv") continue;
    EXPECT_EQ(read(e.path()), read(plane.dir / "near_flow" / "series" / e.path().filename())) << e.path();
  }
  // run.csv too, but for its active_boundary column: the wall particles in the cells the neighbour search visits
  // (2h boxes around the flow's cells), some of them beyond the kernel's reach, where near_flow laid none. Never
  // more.
  auto rows = [](const std::string& text) {
    std::vector<std::pair<std::string, long>> out;
    std::stringstream in(text);
    std::string line, cell;
    std::getline(in, line);
    std::vector<std::string> header;
    for (std::stringstream h(line); std::getline(h, cell, ',');) header.push_back(cell);
    const size_t column = std::find(header.begin(), header.end(), "active_boundary") - header.begin();
    EXPECT_LT(column, header.size()) << line;
    while (std::getline(in, line)) {
      std::string rest;
      long active = -1;
      size_t k = 0;
      for (std::stringstream r(line); std::getline(r, cell, ','); ++k)
        if (k == column) active = std::stol(cell);
        else rest += cell + ',';
      out.push_back({rest, active});
    }
    return out;
  };
  const auto a = rows(read(plane.dir / "all" / "series" / "run.csv"));
  const auto b = rows(read(plane.dir / "near_flow" / "series" / "run.csv"));
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].first, b[k].first) << "row " << k;
    EXPECT_LE(b[k].second, a[k].second) << "row " << k;
  }
}

// The run's domain (its closed bottom) is the same whichever way the bed is laid: with the bed laid near the
// flow only, it must still reach under the whole bed, not stop 4h under the release.
TEST(BedWalls, TheDomainIsTheWholeBedsEitherWay) {
  const Plane plane;
  const Scene near = parse_scene(plane.scene("near_flow").dump(), plane.dir);
  const Scene whole = parse_scene(plane.scene("all").dump(), plane.dir);
  const SolverConfig& a = std::get<SceneSetup<3>>(near.setup).config;
  const SolverConfig& b = std::get<SceneSetup<3>>(whole.setup).config;
  for (int d = 0; d < 3; ++d) EXPECT_EQ(a.domain_min[d], b.domain_min[d]) << d;
  for (int d = 0; d < 2; ++d) EXPECT_EQ(a.domain_max[d], b.domain_max[d]) << d;  // the top is open
  EXPECT_LT(a.domain_min[2], 60.0 - 0.4 * 80.0) << "the bottom is under the plane's lowest point";
}

TEST(BedWalls, AnUnknownWallsChoiceIsRefusedNamingTheField) {
  const Plane plane;
  try {
    parse_scene(plane.scene("some").dump(), plane.dir);
    FAIL() << "expected a SceneError";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, "terrain.walls");
    EXPECT_NE(std::string(e.what()).find("near_flow"), std::string::npos) << e.what();
  }
}

// The cost model's features of a terrain scene: the bed laid near the flow counts apart from the fixed walls
// (the prediction of what is alive reads it; the 4 x 6 x 1 m release is 192 particles at dp 0.5).
TEST(BedWalls, CostFeaturesCountTheBedApartFromTheFixedWalls) {
  const Plane plane;
  const CostFeatures near = cost_features(parse_scene(plane.scene("near_flow").dump(), plane.dir));
  const CostFeatures whole = cost_features(parse_scene(plane.scene("all").dump(), plane.dir));
  EXPECT_EQ(near.fluid, 192);
  EXPECT_EQ(near.fluid_peak, 192);
  EXPECT_EQ(near.boundary, whole.boundary);
  EXPECT_EQ(near.boundary, near.boundary_fixed + near.bed);
  EXPECT_GT(near.bed, 0);
  EXPECT_EQ(whole.bed, 0);  // laid whole at the start: fixed
  const CostModel model = CostModel::calibrated();
  EXPECT_EQ(model.predict(whole, 1).boundary_peak, whole.boundary);
  EXPECT_EQ(model.predict(near, 1).boundary_peak,
            near.boundary_fixed + std::min(near.bed, model.bed_per_flow_column * std::pow(192.0, 2.0 / 3.0)));
}
