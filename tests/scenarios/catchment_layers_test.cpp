// The shipped catchment sweep whose layout lives in scenarios/catchment/layouts.gpkg
// (scripts/make_catchment_layouts.py) builds exactly the terrain of the coordinate-list scene. A validation
// test: each build of the Jacksboro terrain takes about half a minute (the DEM warped to 10 m and its corridor).
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;

template <class Setup>
void expect_same_particles(const Setup& a, const Setup& b, double tol) {
  ASSERT_EQ(a.fluid.size(), b.fluid.size());
  ASSERT_EQ(a.boundary.size(), b.boundary.size());
  double worst = 0;
  for (size_t k = 0; k < a.fluid.size(); ++k)
    for (int d = 0; d < 3; ++d) worst = std::max(worst, std::abs(a.fluid.pos[d][k] - b.fluid.pos[d][k]));
  for (size_t k = 0; k < a.boundary.size(); ++k) {
    for (int d = 0; d < 3; ++d) worst = std::max(worst, std::abs(a.boundary.pos[d][k] - b.boundary.pos[d][k]));
    ASSERT_EQ(a.boundary.tag[k], b.boundary.tag[k]) << k;
  }
  EXPECT_LE(worst, tol);
}

void expect_same_scene(const Scene& a, const Scene& b, double tol) {
  expect_same_particles(std::get<SceneSetup<3>>(a.setup), std::get<SceneSetup<3>>(b.setup), tol);
  EXPECT_EQ(a.boundary_tags, b.boundary_tags);
  ASSERT_EQ(a.terrain->structures.size(), b.terrain->structures.size());
  for (size_t k = 0; k < a.terrain->structures.size(); ++k) {
    EXPECT_EQ(a.terrain->structures[k].name, b.terrain->structures[k].name);
    EXPECT_NEAR(a.terrain->structures[k].storage_capacity, b.terrain->structures[k].storage_capacity,
                1e-9 * (1 + a.terrain->structures[k].storage_capacity));
  }
  EXPECT_DOUBLE_EQ(a.terrain->release_volume, b.terrain->release_volume);
  ASSERT_EQ(a.monitors.size(), b.monitors.size());
  for (size_t k = 0; k < a.monitors.size(); ++k) {
    ASSERT_EQ(a.monitors[k].points.size(), b.monitors[k].points.size());
    for (size_t q = 0; q < a.monitors[k].points.size(); ++q)
      for (int d = 0; d < 2; ++d) EXPECT_NEAR(a.monitors[k].points[q][d], b.monitors[k].points[q][d], tol);
  }
}

}  // namespace

TEST(CatchmentLayers, SweepFromTheShippedGeoPackageBuildsTheSameTerrain) {
  // scenarios/catchment/jacksboro_g_gpkg.json against jacksboro_g.json, both with all three dams (G7): same
  // particles, structures, zone and sections.
  const Sweep inline_sweep = load_sweep(kSource / "scenarios/catchment/g0_g7.json");
  const Sweep gpkg_sweep = load_sweep(kSource / "scenarios/catchment/g0_g7_gpkg.json");
  ASSERT_EQ(inline_sweep.variants.size(), gpkg_sweep.variants.size());
  const SweepVariant& g7 = inline_sweep.variants.back();
  ASSERT_EQ(g7.structures.size(), 3u);
  Fidelity coarse;  // dp 8 m: the same geometry at a quarter of draft's particle count per area
  coarse.name = "custom";
  coarse.dp = 8.0;
  const Scene a = parse_scene(resolve_variant(inline_sweep.base_json, g7, coarse), inline_sweep.base_path.parent_path());
  const Scene b = parse_scene(resolve_variant(gpkg_sweep.base_json, g7, coarse), gpkg_sweep.base_path.parent_path());
  expect_same_scene(a, b, 0.0);
  ASSERT_EQ(a.terrain->protected_zones.size(), 1u);
  EXPECT_EQ(a.terrain->protected_zones[0].polygon, b.terrain->protected_zones[0].polygon);
  // The run's identity follows the GeoPackage's bytes.
  const Manifest m = make_manifest(resolve_variant(gpkg_sweep.base_json, g7, coarse), gpkg_sweep.base_path.parent_path(),
                                   coarse);
  EXPECT_NE(json::parse(m.json).at("layer_sha256").at("layouts.gpkg").get<std::string>(), "missing");
}

