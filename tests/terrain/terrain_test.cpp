// Terrain scenes on a synthetic valley whose geometry is known exactly: corridor, structures (storage and
// regrading volumes against the analytic geometry), release, misplaced-particle checks, refused inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using namespace runout;
using namespace runout::terrain;

namespace {

// A straight valley draining east: z = z0 + s (Lx - x) + a max(0, |y - yc| - w/2), i.e. a flat floor w wide
// with side slopes a, falling at s along x. Map coordinates: UTM 16N, lower-left corner at (E0, N0).
struct Valley {
  double E0 = 600000.0, N0 = 4000000.0;
  double Lx = 160.0, Ly = 61.0, cell = 1.0;  // yc = 30.5 is a cell centre: the DEM holds the kink exactly
  double z0 = 300.0, s = 0.2, a = 0.5, w = 0.0;
  double yc() const { return 0.5 * Ly; }
  double z(double x, double y) const { return z0 + s * (Lx - x) + a * std::max(0.0, std::abs(y - yc()) - 0.5 * w); }
  MapPoint at(double x, double y) const { return {E0 + x, N0 + y}; }
  Grid grid(int pad_factor = 1) const {
    // pad_factor > 1 embeds the valley in a grid pad_factor times wider and taller, on high ground.
    const int nx = static_cast<int>(Lx / cell), ny = static_cast<int>(Ly / cell);
    const int px = nx * (pad_factor - 1) / 2, py = ny * (pad_factor - 1) / 2;
    Grid g(nx * pad_factor, ny * pad_factor, E0 - px * cell, N0 + (ny + py) * cell, cell, cell,
           crs_wkt_from("EPSG:32616"), static_cast<float>(z0 + s * Lx + a * Ly + 50.0));
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) g.at(px + i, py + j) = static_cast<float>(z((i + 0.5) * cell, Ly - (j + 0.5) * cell));
    return g;
  }
};

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("runout-terrain-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
                                        "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

TerrainSpec base_spec(const Valley& v, const std::string& dem) {
  TerrainSpec spec;
  spec.dem_path = dem;
  spec.release.polygon = {v.at(40, 25), v.at(50, 25), v.at(50, 35), v.at(40, 35)};
  spec.release.depth = 1.0;
  spec.corridor.travel_angle_deg = 8.0;
  spec.corridor.buffer_m = 5.0;
  return spec;
}

// Every wall particle of a model: the structures' and all of the bed source's tiles.
std::vector<Vec<3>> all_wall_particles(const TerrainModel& m) {
  std::vector<Vec<3>> pos = m.boundary, normals;
  std::vector<uint32_t> tags;
  const auto src = bed_wall_source(std::make_shared<const TerrainModel>(m));
  for (int64_t t = 0; t < src->tiles().count(); ++t) src->lay(t, pos, normals, tags);
  return pos;
}

// Midpoint-rule integral over a rectangle of the map plane at a fine step (independent of dp).
template <class F>
double integrate(double x0, double x1, double y0, double y1, F f, double step = 0.02) {
  double sum = 0;
  for (double y = y0 + 0.5 * step; y < y1; y += step)
    for (double x = x0 + 0.5 * step; x < x1; x += step) sum += f(x, y);
  return sum * step * step;
}

}  // namespace

TEST(TerrainBuild, ReleaseSitsOnTheBedWithItsVolumeAndNoParticleIsMisplaced) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  const double dp = 0.5;
  TerrainModel m = build_terrain(base_spec(v, (tmp.path / "valley.tif").string()), dp);
  // 10 m x 10 m x 1 m release: 20 x 20 columns of 2 particles.
  EXPECT_EQ(m.fluid.size(), 800u);
  EXPECT_NEAR(m.release_volume, 100.0, 1e-9);
  for (size_t q = 0; q < m.fluid.size(); ++q) {
    const auto& p = m.fluid[q];
    const double x = p[0] + m.origin_x - v.E0, y = p[1] + m.origin_y - v.N0;
    const double above = p[2] - v.z(x, y);
    EXPECT_TRUE(std::abs(above - 0.25) < 1e-3 || std::abs(above - 0.75) < 1e-3) << above;
    EXPECT_EQ(m.misplaced(p), "");
  }
  // The ground under every boundary column is the valley surface (bilinear on a piecewise-linear surface
  // is exact away from the thalweg kink, within s*cell/2 near it).
  size_t top_count = 0;
  const std::vector<Vec<3>> walls = all_wall_particles(m);
  for (size_t q = 0; q < walls.size(); ++q) {
    const auto& p = walls[q];
    const double x = p[0] + m.origin_x - v.E0, y = p[1] + m.origin_y - v.N0;
    const double b = m.bed_at(p[0], p[1]);
    if (std::abs(p[2] - (b - 0.5 * dp)) < 1e-6) {
      ++top_count;
      EXPECT_NEAR(b, v.z(x, y), 0.5 * v.a * v.cell) << x << ", " << y;
    }
  }
  EXPECT_GT(top_count, 0u);
  // A particle half a spacing under the first layer is under the ground; one above the flow is fine.
  const Vec<3> p0 = m.fluid[0];
  const double b0 = m.bed_at(p0[0], p0[1]);
  EXPECT_NE(m.misplaced(Vec<3>(p0[0], p0[1], b0 - 1.5 * dp)).find("below the terrain"), std::string::npos);
  EXPECT_EQ(m.misplaced(Vec<3>(p0[0], p0[1], b0 + 3.0)), "");
}

TEST(TerrainBuild, SteepGroundGetsABoundarySheetWithoutHoles) {
  // Every column's particles reach down to its lowest neighbour's surface minus the layers, so a particle
  // moving sideways from any column meets boundary particles no more than dp apart vertically.
  TempDir tmp;
  Valley v;
  v.a = 2.0;  // 63 degree valley sides
  write_geotiff((tmp.path / "steep.tif").string(), v.grid());
  const double dp = 0.5;
  TerrainSpec spec = base_spec(v, (tmp.path / "steep.tif").string());
  TerrainModel m = build_terrain(spec, dp);
  std::map<std::pair<long, long>, std::pair<double, double>> col;  // (i, j) -> (lowest, highest particle)
  for (const auto& p : all_wall_particles(m)) {
    auto key = std::make_pair(std::lround(p[0] / dp - 0.5), std::lround(p[1] / dp - 0.5));
    auto it = col.find(key);
    if (it == col.end()) col[key] = {p[2], p[2]};
    else it->second = {std::min(it->second.first, p[2]), std::max(it->second.second, p[2])};
  }
  size_t checked = 0;
  for (const auto& [key, range] : col) {
    for (int d = 0; d < 4; ++d) {
      auto nk = std::make_pair(key.first + (d == 0) - (d == 1), key.second + (d == 2) - (d == 3));
      auto it = col.find(nk);
      if (it == col.end()) continue;
      // This column's sheet reaches at least (layers - 1) dp below the neighbour's top particle.
      EXPECT_LE(range.first, it->second.second - (spec.layers - 1) * dp + 1e-6);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000u);
}

TEST(TerrainBuild, CorridorRunsDownTheValleyAndOpensTheDemEdgeItReaches) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  TerrainModel a = build_terrain(base_spec(v, (tmp.path / "valley.tif").string()), 0.5);
  EXPECT_LT(a.modelled_fraction, 0.9);
  EXPECT_GT(a.modelled_fraction, 0.05);
  double xmin = 1e300, xmax = -1e300;
  for (const auto& p : all_wall_particles(a)) xmin = std::min(xmin, p[0] + a.origin_x - v.E0), xmax = std::max(xmax, p[0] + a.origin_x - v.E0);
  // Upstream the energy line from the release's highest edge (3.5 m over the thalweg at y = 25) meets the
  // thalweg, rising 0.2/m against a line falling tan 8 deg = 0.14/m, within 3.5 / 0.34 = 10.3 m; the buffer
  // (5 m) and a cell come on top.
  EXPECT_GE(xmin, 40.0 - 3.5 / (0.2 + std::tan(8.0 * M_PI / 180.0)) - 5.0 - 1.5);
  EXPECT_LT(xmin, 40.0 - 5.0);
  // Downstream it runs to the end of this 160 m valley (slope 0.2 > tan 8 deg = 0.14).
  EXPECT_GT(xmax, v.Lx - 1.0);
  EXPECT_TRUE(a.open_faces[0][1]);  // the east edge of the DEM: flow may leave there
  EXPECT_FALSE(a.open_faces[0][0]);

  // Where the flow leaves the model: over a column off the corridor (inside its box) and past the box's
  // closed faces; not on the corridor, nor past the open east face (the engine's outflow from the DEM).
  const double east = a.bed.x1() - a.origin_x, north = a.bed.y0 - a.origin_y;
  const double yc = v.yc() - (a.origin_y - v.N0);  // the thalweg, local
  EXPECT_FALSE(a.off_corridor(Vec<3>(0.5 * east, yc, a.bed_at(0.5 * east, yc) + 0.5)));
  EXPECT_TRUE(a.off_corridor(Vec<3>(-0.5, yc, 400.0)));         // upstream of the box: a closed face
  EXPECT_FALSE(a.off_corridor(Vec<3>(east + 0.5, yc, 250.0)));  // past the DEM's east edge
  EXPECT_EQ(a.off_corridor(Vec<3>(0.5 * east, north + 0.5, 400.0)), !a.open_faces[1][1]);
  size_t off = 0;  // the reach is not a rectangle: some columns in its box are off it
  for (int j = 0; j < a.bed.ny; ++j)
    for (int i = 0; i < a.bed.nx; ++i)
      if (std::isnan(a.bed.at(i, j))) {
        EXPECT_TRUE(a.off_corridor(Vec<3>(a.bed.cx(i) - a.origin_x, a.bed.cy(j) - a.origin_y, 400.0))) << i << ' ' << j;
        ++off;
      }
  EXPECT_GT(off, 0u);
}

TEST(TerrainBuild, CorridorIgnoresTheRestOfALargerDem) {
  TempDir tmp;
  Valley v;
  v.s = 0.1;  // the reach stops inside the valley (see TravelAngleStops...)
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  write_geotiff((tmp.path / "padded.tif").string(), v.grid(4));  // 16x the area, on high ground
  TerrainSpec sa = base_spec(v, (tmp.path / "valley.tif").string()), sb = sa;
  sa.corridor.travel_angle_deg = sb.corridor.travel_angle_deg = 11.0;
  sb.dem_path = (tmp.path / "padded.tif").string();
  TerrainModel a = build_terrain(sa, 0.5);
  TerrainModel b = build_terrain(sb, 0.5);
  EXPECT_NEAR(b.modelled_fraction * 16.0, a.modelled_fraction, 1e-9);
  EXPECT_EQ(all_wall_particles(a).size(), all_wall_particles(b).size());
  EXPECT_EQ(a.fluid.size(), b.fluid.size());
  EXPECT_DOUBLE_EQ(a.corridor_area, b.corridor_area);
  EXPECT_DOUBLE_EQ(a.origin_x, b.origin_x);
  EXPECT_DOUBLE_EQ(a.origin_y, b.origin_y);
}

TEST(TerrainBuild, TravelAngleStopsTheCorridorWhereTheEnergyLineMeetsTheGround) {
  TempDir tmp;
  Valley v;
  v.s = 0.1;  // a plane gentler than tan(11 deg) = 0.194: the energy line from a 1 m deep release falls faster
  v.a = 0.0;
  write_geotiff((tmp.path / "plane.tif").string(), v.grid());
  TerrainSpec spec = base_spec(v, (tmp.path / "plane.tif").string());
  spec.corridor.travel_angle_deg = 11.0;
  spec.corridor.buffer_m = 2.0;
  TerrainModel m = build_terrain(spec, 0.5);
  double xmax = -1e300;
  for (const auto& p : all_wall_particles(m)) xmax = std::max(xmax, p[0] + m.origin_x - v.E0);
  // Head at the release's downstream edge x = 50: z(50) + 1; ground falls 0.1/m, the line 0.194/m, so they
  // meet 1 / (0.194 - 0.1) = 10.6 m further, plus the buffer and up to a DEM cell of rounding.
  const double reach = 50.0 + 1.0 / (std::tan(11.0 * M_PI / 180.0) - 0.1);
  EXPECT_GT(xmax, reach + 2.0 - 1.5);
  EXPECT_LT(xmax, reach + 2.0 + 1.5);
}

// The corridor's reach is kept per (DEM, release, corridor, dp): a second build of one scene takes it from the
// keep and is the same model; another travel angle, or the DEM's file changed in place, is computed afresh.
TEST(TerrainBuild, TheReachIsKeptForTheSameDemReleaseAndCorridorOnly) {
  TempDir tmp;
  Valley v;
  const std::string dem = (tmp.path / "kept.tif").string();
  write_geotiff(dem, v.grid());
  const TerrainSpec spec = base_spec(v, dem);
  const KeptReachStats s0 = kept_reach_stats();
  const TerrainModel a = build_terrain(spec, 0.5), b = build_terrain(spec, 0.5);
  const KeptReachStats s1 = kept_reach_stats();
  EXPECT_EQ(s1.misses - s0.misses, 1);
  EXPECT_EQ(s1.hits - s0.hits, 1);
  EXPECT_EQ(all_wall_particles(a), all_wall_particles(b));
  EXPECT_EQ(a.fluid.size(), b.fluid.size());
  EXPECT_EQ(a.max_energy_height, b.max_energy_height);
  EXPECT_EQ(a.corridor_area, b.corridor_area);

  TerrainSpec steeper = spec;
  steeper.corridor.travel_angle_deg = 20.0;  // a shorter reach
  const TerrainModel c = build_terrain(steeper, 0.5);
  EXPECT_EQ(kept_reach_stats().misses - s1.misses, 1);
  EXPECT_LT(c.corridor_area, a.corridor_area);

  Valley flatter = v;
  flatter.s = 0.1;  // the reach stops inside the valley (TravelAngleStops...)
  write_geotiff(dem, flatter.grid());
  const TerrainModel d = build_terrain(spec, 0.5);
  EXPECT_EQ(kept_reach_stats().misses - s1.misses, 2);
  EXPECT_LT(d.corridor_area, a.corridor_area);
}

// A structure type is its file: every registered type declares its geometry first (an axis of 2 points or a
// polygon of 3, as `area` says) and carries its behaviour, so build_terrain and the run need no switch on it.
TEST(TerrainStructures, EveryTypeDeclaresItsGeometryAndBehaviour) {
  ASSERT_FALSE(structure_types().empty());
  for (const auto* t : structure_types()) {
    ASSERT_FALSE(t->fields.empty()) << t->name;
    EXPECT_EQ(t->fields.front().shape, "polyline") << t->name;
    EXPECT_EQ(t->fields.front().min_points, t->area ? 3u : 2u) << t->name;
    EXPECT_TRUE(t->check && t->holds && t->steps) << t->name;
    EXPECT_FALSE(t->label.empty() || t->colour.size() != 7) << t->name;
    EXPECT_EQ(&structure_type(t->name), t) << t->name;
  }
}

TEST(TerrainStructures, CheckDamStoresTheWedgeUpstreamOfItsFace) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  const double dp = 0.25, H = 3.0, t = 1.0, xd = 80.0;
  TerrainSpec spec = base_spec(v, (tmp.path / "valley.tif").string());
  StructureSpec dam;
  dam.type = &structure_type("check_dam");
  dam.name = "Dam1";
  dam.line = {v.at(xd, 5.0), v.at(xd, 55.0)};
  dam.numbers["crest_height"] = H;
  dam.numbers["thickness"] = t;
  spec.structures.push_back(dam);
  TerrainModel m = build_terrain(spec, dp);
  ASSERT_EQ(m.structures.size(), 1u);
  const auto& info = m.structures[0];
  EXPECT_NEAR(info.crest_elevation, v.z(xd, v.yc()) + H, 0.5 * v.s * v.cell);
  // Pool level with the crest from the face at xd - t/2: V = (H - s t/2)^3 / (3 a s) (x-sections are
  // triangles of depth D and width 2D/a).
  const double analytic = std::pow(H - v.s * 0.5 * t, 3) / (3.0 * v.a * v.s);
  EXPECT_NEAR(info.storage_capacity, analytic, 0.03 * analytic);
  // Its wall particles rise to the crest and carry the dam's tag.
  double top = -1e300;
  size_t n = 0;
  for (size_t q = 0; q < m.boundary.size(); ++q)
    if (m.boundary_tag[q] == info.tag) top = std::max(top, m.boundary[q][2]), ++n;
  EXPECT_GT(n, 0u);
  EXPECT_NEAR(top, info.crest_elevation - 0.5 * dp, 0.5 * dp + 1e-6);
  // Inside the dam is a misplaced place; the pool above the bed is not.
  const double lx = v.E0 + xd - m.origin_x, ly = v.N0 + v.yc() - m.origin_y;
  EXPECT_NE(m.misplaced(Vec<3>(lx, ly, v.z(xd, v.yc()) + 1.0)).find("inside the wall of 'Dam1'"), std::string::npos);
  EXPECT_EQ(m.misplaced(Vec<3>(lx - 3.0, ly, v.z(xd - 3.0, v.yc()) + 1.0)), "");
}

TEST(TerrainStructures, SlitLowersTheWallToItsSill) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  const double dp = 0.25, xd = 80.0;
  TerrainSpec spec = base_spec(v, (tmp.path / "valley.tif").string());
  StructureSpec dam;
  dam.type = &structure_type("check_dam");
  dam.name = "SlitDam";
  dam.line = {v.at(xd, 5.0), v.at(xd, 55.0)};
  dam.numbers["crest_height"] = 3.0;
  dam.numbers["thickness"] = 1.0;
  dam.numbers["slit.width"] = 2.0;
  dam.numbers["slit.bottom"] = 1.0;
  spec.structures.push_back(dam);
  TerrainModel m = build_terrain(spec, dp);
  const double thalweg = m.structures[0].crest_elevation - 3.0;
  EXPECT_NEAR(thalweg, v.z(xd, v.yc()), 1e-3);
  double top_in_slit = -1e300, top_outside = -1e300;
  for (size_t q = 0; q < m.boundary.size(); ++q) {
    if (m.boundary_tag[q] != m.structures[0].tag) continue;
    const double y = m.boundary[q][1] + m.origin_y - v.N0;
    (std::abs(y - v.yc()) < 1.0 - 0.5 * dp ? top_in_slit : top_outside) =
        std::max(std::abs(y - v.yc()) < 1.0 - 0.5 * dp ? top_in_slit : top_outside, m.boundary[q][2]);
  }
  EXPECT_NEAR(top_in_slit, thalweg + 1.0 - 0.5 * dp, 0.5 * dp + 1e-6);
  EXPECT_NEAR(top_outside, thalweg + 3.0 - 0.5 * dp, 0.5 * dp + 1e-6);
}

TEST(TerrainStructures, DepositionAreaRegradesToItsPlaneWithTheGeometricCutAndFill) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  const double dp = 0.25;
  const double x1 = 60, x2 = 90, y1 = 20, y2 = 40;
  const double e = v.z(75.0, v.yc()) + 1.0;  // flat, 1 m above the thalweg at the middle
  TerrainSpec spec = base_spec(v, (tmp.path / "valley.tif").string());
  StructureSpec area;
  area.type = &structure_type("deposition_area");
  area.name = "Flat1";
  area.line = {v.at(x1, y1), v.at(x2, y1), v.at(x2, y2), v.at(x1, y2)};
  area.numbers["elevation"] = e;
  spec.structures.push_back(area);
  TerrainModel m = build_terrain(spec, dp);
  const auto& info = m.structures[0];
  const double fill = integrate(x1, x2, y1, y2, [&](double x, double y) { return std::max(0.0, e - v.z(x, y)); });
  const double cut = integrate(x1, x2, y1, y2, [&](double x, double y) { return std::max(0.0, v.z(x, y) - e); });
  EXPECT_NEAR(info.fill_volume, fill, 0.03 * fill);
  EXPECT_NEAR(info.cut_volume, cut, 0.03 * cut);
  EXPECT_EQ(info.tag, 0u);  // no wall
  // The bed inside is the plane.
  EXPECT_NEAR(m.bed_at(v.E0 + 75.0 - m.origin_x, v.N0 + 30.0 - m.origin_y), e, 1e-4);
  EXPECT_NEAR(m.bed_at(v.E0 + 62.0 - m.origin_x, v.N0 + 22.0 - m.origin_y), e, 1e-4);
}

TEST(TerrainStructures, DepositionAreaGradientFallsDownTheValley) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  const double dp = 0.5;
  TerrainSpec spec = base_spec(v, (tmp.path / "valley.tif").string());
  StructureSpec area;
  area.type = &structure_type("deposition_area");
  area.name = "Gentle";
  area.line = {v.at(60, 20.5), v.at(90, 20.5), v.at(90, 40.5), v.at(60, 40.5)};  // symmetric about the thalweg
  area.numbers["gradient"] = 0.05;
  spec.structures.push_back(area);
  TerrainModel m = build_terrain(spec, dp);
  const double za = m.bed_at(v.E0 + 65.0 - m.origin_x, v.N0 + 30.0 - m.origin_y);
  const double zb = m.bed_at(v.E0 + 85.0 - m.origin_x, v.N0 + 30.0 - m.origin_y);
  EXPECT_NEAR((za - zb) / 20.0, 0.05, 1e-3);  // falls east, the valley's way, at the given gradient
  const double zc = m.bed_at(v.E0 + 75.0 - m.origin_x, v.N0 + 22.5 - m.origin_y);
  const double zd = m.bed_at(v.E0 + 75.0 - m.origin_x, v.N0 + 38.5 - m.origin_y);
  EXPECT_NEAR(zc, zd, 1e-3);  // level across
}

TEST(TerrainStructures, RetentionBasinHoldsItsExcavationAndWallsUpToTheLowestRim) {
  TempDir tmp;
  Valley v;
  v.s = 0.1;
  v.w = 30.0;  // a flat floor 30 m wide
  write_geotiff((tmp.path / "floor.tif").string(), v.grid());
  const double dp = 0.25, d = 1.0, hw = 1.0, wt = 1.0;
  const double x1 = 70, x2 = 90, b = 20.0;  // basin 20 m x 20 m on the floor
  TerrainSpec spec = base_spec(v, (tmp.path / "floor.tif").string());
  StructureSpec basin;
  basin.type = &structure_type("retention_basin");
  basin.name = "Basin";
  // Vertices: edge 0 upstream (x1), edge 1 north side, edge 2 downstream (x2), edge 3 south side.
  basin.line = {v.at(x1, 20), v.at(x1, 40), v.at(x2, 40), v.at(x2, 20)};
  basin.numbers["depth"] = d;
  basin.numbers["wall_height"] = hw;
  basin.numbers["wall_thickness"] = wt;
  spec.structures.push_back(basin);
  TerrainModel m = build_terrain(spec, dp);
  const auto& info = m.structures[0];
  // Default open edge is the highest one: the upstream edge 0. Level: the downstream wall's top.
  EXPECT_NEAR(info.crest_elevation, v.z(x2, v.yc()) + hw, 0.05);
  EXPECT_NEAR(info.cut_volume, d * 20.0 * 20.0, 0.03 * d * 400.0);
  // Storage between the walls' inner faces: depth hw + d - s u at distance u upstream of the downstream edge.
  const double h = 0.5 * wt, L = x2 - x1;
  const double width = b - 2 * h;
  const double analytic = width * ((hw + d) * (L - h) - 0.5 * v.s * (L * L - h * h));
  EXPECT_NEAR(info.storage_capacity, analytic, 0.03 * analytic);
  // Walls on three sides only: none along the upstream edge (the side walls' round ends aside).
  for (size_t q = 0; q < m.boundary.size(); ++q)
    if (m.boundary_tag[q] == info.tag && std::abs(m.boundary[q][1] + m.origin_y - v.N0 - 30.0) < 9.0) {
      EXPECT_GT(m.boundary[q][0] + m.origin_x - v.E0, x1 + h - 1e-6);
    }
}

TEST(TerrainInputs, BadInputsAreRefusedNamingTheField) {
  TempDir tmp;
  Valley v;
  write_geotiff((tmp.path / "valley.tif").string(), v.grid());
  const std::string dem = (tmp.path / "valley.tif").string();
  auto field_of = [&](const TerrainSpec& spec, double dp = 0.5) -> std::string {
    try {
      build_terrain(spec, dp);
    } catch (const TerrainError& e) {
      return e.field + " | " + e.what();
    }
    return "accepted";
  };
  {  // release outside the DEM
    TerrainSpec s = base_spec(v, dem);
    s.release.polygon = {v.at(-50, 10), v.at(-40, 10), v.at(-40, 20)};
    EXPECT_NE(field_of(s).find("release.polygon | release.polygon: the release: vertex"), std::string::npos) << field_of(s);
  }
  {  // structure outside the DEM
    TerrainSpec s = base_spec(v, dem);
    StructureSpec dam;
    dam.type = &structure_type("check_dam");
    dam.name = "Far";
    dam.line = {v.at(80, 5), v.at(80, 500)};
    dam.numbers["crest_height"] = 2, dam.numbers["thickness"] = 1;
    s.structures.push_back(dam);
    EXPECT_NE(field_of(s).find("structures[0] | structures[0]: 'Far': vertex"), std::string::npos) << field_of(s);
  }
  {  // overlapping structures
    TerrainSpec s = base_spec(v, dem);
    StructureSpec a;
    a.type = &structure_type("deposition_area");
    a.name = "A";
    a.line = {v.at(60, 20), v.at(90, 20), v.at(90, 40), v.at(60, 40)};
    StructureSpec dam;
    dam.type = &structure_type("check_dam");
    dam.name = "B";
    dam.line = {v.at(80, 5), v.at(80, 55)};
    dam.numbers["crest_height"] = 2, dam.numbers["thickness"] = 1;
    s.structures = {a, dam};
    const std::string r = field_of(s);
    EXPECT_NE(r.find("structures[1]"), std::string::npos) << r;
    EXPECT_NE(r.find("'B' overlaps structures[0] ('A')"), std::string::npos) << r;
  }
  {  // nodata under the release
    Grid g = v.grid();
    for (int j = 25; j < 35; ++j)
      for (int i = 42; i < 45; ++i) g.at(i, j) = Grid::nodata;
    write_geotiff((tmp.path / "holes.tif").string(), g);
    TerrainSpec s = base_spec(v, (tmp.path / "holes.tif").string());
    const std::string r = field_of(s);
    EXPECT_NE(r.find("release.polygon"), std::string::npos) << r;
    EXPECT_NE(r.find("no DEM data"), std::string::npos) << r;
  }
  {  // an unreadable DEM
    TerrainSpec s = base_spec(v, (tmp.path / "missing.tif").string());
    EXPECT_EQ(field_of(s).rfind("terrain.dem", 0), 0u) << field_of(s);
  }
  {  // too many particles for the limit
    TerrainSpec s = base_spec(v, dem);
    try {
      build_terrain(s, 0.05, 100000);
      ADD_FAILURE() << "accepted";
    } catch (const TerrainError& e) {
      EXPECT_EQ(e.field, "dp");
    }
  }
}

// The leak check at steps of the column lattice. The bed and the walls are columns of particles at dp, the
// first layer's centres dp/2 under each column's top. A particle resting beside a step (on the low columns,
// short of the high columns' line) is where the flow may be, though it is under the surface interpolated
// across the step; one that has crossed the high columns' line below their first layer has leaked. A hand-made
// model, dp = 1 m, origin 0: the bed is 0 for columns i < 5 and 6 m for i >= 5 (a cut face, centre line
// x = 5.5); a wall on rows j >= 5 (y < 5) of columns 12-17 has its top at 2 m for i < 15 and 5 m from i = 15
// (a wall whose top follows the ground; step line x = 15.5).
TEST(TerrainLeakCheck, ARestBesideAStepIsNoLeakACrossingIs) {
  TerrainModel m;
  m.dp = 1.0;
  m.bed = Grid(20, 10, 0.0, 10.0, 1.0, 1.0, "", 0.0f);
  for (int j = 0; j < 10; ++j)
    for (int i = 5; i < 10; ++i) m.bed.at(i, j) = 6.0f;
  m.wall_top = m.bed.like(Grid::nodata);
  m.wall_owner.assign(m.bed.values.size(), -1);
  StructureInfo wall;
  wall.name = "Wall";
  m.structures.push_back(wall);
  for (int j = 5; j < 10; ++j)
    for (int i = 12; i < 18; ++i) {
      m.wall_top.at(i, j) = i < 15 ? 2.0f : 5.0f;
      m.wall_owner[static_cast<size_t>(j) * 20 + i] = 0;
    }
  m.wall_interior.assign(m.bed.values.size(), 0);  // as build_walls marks them: all four neighbours wall
  for (int j = 6; j < 9; ++j)
    for (int i = 13; i < 17; ++i) m.wall_interior[static_cast<size_t>(j) * 20 + i] = 1;
  // Beside the cut face, 0.7 m above the low bed, 0.6 and 0.3 dp short of the face's column line: the old
  // check (1 dp under the interpolated surface, 2.4 and 4.2 m there) took both for leaks.
  EXPECT_EQ(m.misplaced(Vec<3>(4.9, 7.5, 0.7)), "");
  EXPECT_EQ(m.misplaced(Vec<3>(5.2, 7.5, 0.7)), "");
  // Past the face's line, more than dp under the high columns' top: between their first-layer particles.
  EXPECT_NE(m.misplaced(Vec<3>(5.7, 7.5, 0.7)).find("below the terrain"), std::string::npos);
  // Under the low bed by more than dp, anywhere.
  EXPECT_NE(m.misplaced(Vec<3>(2.0, 7.5, -1.2)).find("below the terrain"), std::string::npos);
  // On the wall's low part beside its step, 0.8 m above it: no leak (the old check, wall top 5 m in the
  // step column's cell, took it for one).
  EXPECT_EQ(m.misplaced(Vec<3>(15.2, 2.5, 2.8)), "");
  // In the wall's first column (its face layer), under its top: not yet past the first layer.
  EXPECT_EQ(m.misplaced(Vec<3>(12.3, 2.5, 0.5)), "");
  // Past the step's line under the high part, and in the low part's second column: inside the wall.
  EXPECT_NE(m.misplaced(Vec<3>(15.8, 2.5, 2.8)).find("inside the wall of 'Wall'"), std::string::npos);
  EXPECT_NE(m.misplaced(Vec<3>(13.5, 2.5, 0.5)).find("inside the wall of 'Wall'"), std::string::npos);
  // Short of the wall's outer column line, on the bed beside it: not inside.
  EXPECT_EQ(m.misplaced(Vec<3>(11.8, 2.5, 0.5)), "");
}

// A wall's particles are whole layers from the bed, so they may end up to dp/2 under its nominal top (a dam's
// crest is one level along its axis while the ground under it varies: Jacksboro's Dam1 at dp 2 m, crest
// 4.99 m over a column's bed, 2 particles laid, their top 1 m under the crest). And a wall on the grid's
// diagonal is a staircase: a particle resting in an inner corner sits on an interior column's corner point.
TEST(TerrainLeakCheck, AWallIsWhereItsParticlesEndNotAtItsNominalTop) {
  TerrainModel m;
  m.dp = 1.0;
  m.bed = Grid(20, 10, 0.0, 10.0, 1.0, 1.0, "", 0.0f);
  m.wall_top = m.bed.like(Grid::nodata);
  m.wall_owner.assign(m.bed.values.size(), -1);
  StructureInfo wall;
  wall.name = "Dam";
  m.structures.push_back(wall);
  for (int j = 5; j < 10; ++j)
    for (int i = 12; i < 18; ++i) {
      m.wall_top.at(i, j) = 2.49f;  // round(2.49) = 2 layers: particles at 0.5 and 1.5, top surface 2.0
      m.wall_owner[static_cast<size_t>(j) * 20 + i] = 0;
    }
  m.wall_interior.assign(m.bed.values.size(), 0);
  for (int j = 6; j < 9; ++j)
    for (int i = 13; i < 17; ++i) m.wall_interior[static_cast<size_t>(j) * 20 + i] = 1;
  // In an interior column 1.2 m up: within the top layer (its centre 1.5), not past it; against the nominal
  // top (2.49 - dp = 1.49) this was a leak.
  EXPECT_EQ(m.misplaced(Vec<3>(14.5, 2.5, 1.2)), "");
  // Under the top layer's reach (2.0 - dp): past the first layer, inside.
  EXPECT_NE(m.misplaced(Vec<3>(14.5, 2.5, 0.8)).find("inside the wall of 'Dam'"), std::string::npos);

  // A staircase: the corner column (12, 5) left open, so interior column (13, 6) (centre 13.5, 3.5) touches the
  // pocket at its corner point (13, 4). Just inside (13, 6) at that corner, 0.8 m up: 0.7 dp from the pocket's
  // three wall neighbours' face particles, in the first layer, not past it (Jacksboro Dam1, 45.17 s on two
  // threads); the old check counted it, its own column being interior.
  m.wall_top.at(12, 5) = Grid::nodata;
  m.wall_owner[5 * 20 + 12] = -1;
  EXPECT_EQ(m.misplaced(Vec<3>(13.05, 3.95, 0.8)), "");
  // The same column's centre, with wall all around: inside.
  EXPECT_NE(m.misplaced(Vec<3>(13.6, 3.4, 0.8)).find("inside the wall of 'Dam'"), std::string::npos);
}
