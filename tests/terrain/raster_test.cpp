// Raster I/O: DEM loading and reprojection against an analytic surface and the shipped Jacksboro DEM, GeoTIFF
// and PNG output, and refusal of bad inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <cpl_conv.h>
#include <cpl_string.h>
#include <gdal.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include "runout/terrain/raster.hpp"

namespace fs = std::filesystem;
using namespace runout::terrain;

namespace {

constexpr double kPi = std::numbers::pi;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

// A fresh directory per test under the system temp dir, removed afterwards.
// Named after the executable so that `ctest -R terrain_raster` selects these tests.
class terrain_raster : public ::testing::Test {
 protected:
  void SetUp() override {
    GDALAllRegister();
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() /
          ("runout_raster_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::set<std::string> listing() const {
    std::set<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(dir)) names.insert(e.path().lexically_relative(dir));
    return names;
  }
  fs::path dir;
};

std::string wkt_of(const std::string& user_input) {
  OGRSpatialReference s;
  if (s.SetFromUserInput(user_input.c_str()) != OGRERR_NONE) return "";
  char* w = nullptr;
  s.exportToWkt(&w);
  std::string out = w ? w : "";
  CPLFree(w);
  return out;
}

std::string epsg_code_of(const std::string& wkt) {
  OGRSpatialReference s;
  if (s.importFromWkt(wkt.c_str()) != OGRERR_NONE) return "";
  s.AutoIdentifyEPSG();
  const char* code = s.GetAuthorityCode(nullptr);
  return code ? code : "";
}

// Writes a single-band Float32 GeoTIFF with GDAL directly (crs "" = none).
void write_test_tiff(const fs::path& path, int nx, int ny, const double gt[6], const std::string& crs,
                     const std::vector<float>& values, const double* nodata = nullptr) {
  GDALDriverH drv = GDALGetDriverByName("GTiff");
  ASSERT_NE(drv, nullptr);
  GDALDatasetH ds = GDALCreate(drv, path.c_str(), nx, ny, 1, GDT_Float32, nullptr);
  ASSERT_NE(ds, nullptr);
  double g[6];
  std::copy(gt, gt + 6, g);
  ASSERT_EQ(GDALSetGeoTransform(ds, g), CE_None);
  if (!crs.empty()) {
    ASSERT_EQ(GDALSetProjection(ds, wkt_of(crs).c_str()), CE_None);
  }
  GDALRasterBandH b = GDALGetRasterBand(ds, 1);
  if (nodata) {
    ASSERT_EQ(GDALSetRasterNoDataValue(b, *nodata), CE_None);
  }
  ASSERT_EQ(GDALRasterIO(b, GF_Write, 0, 0, nx, ny, const_cast<float*>(values.data()), nx, ny, GDT_Float32, 0, 0),
            CE_None);
  GDALClose(ds);
}

struct Transformer {
  OGRSpatialReference a, b;
  std::unique_ptr<OGRCoordinateTransformation> ct;
  Transformer(const std::string& from, const std::string& to) {
    EXPECT_EQ(a.SetFromUserInput(from.c_str()), OGRERR_NONE);
    EXPECT_EQ(b.SetFromUserInput(to.c_str()), OGRERR_NONE);
    a.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    b.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    ct.reset(OGRCreateCoordinateTransformation(&a, &b));
    EXPECT_NE(ct, nullptr);
  }
  void operator()(double& x, double& y) const { ASSERT_TRUE(ct->Transform(1, &x, &y)); }
};

// ------------------------------------------------------------------------------------------------------------
// The analytic surface: z = Z0 + A sin(kl (lon - L0)) + B cos(kp (lat - P0)) + C (lat - P0), lon/lat in degrees.
// Its only second derivatives are f_ll = -A kl^2 sin(.) and f_pp = -B kp^2 cos(.), so |f_ll| <= A kl^2 and
// |f_pp| <= B kp^2 (metres per square degree); the mixed derivative is zero.
struct Surface {
  double Z0 = 800, A = 150, B = 120, C = 2000;
  double L0 = 10.0, P0 = 46.0;
  double kl = 2 * kPi / 0.05, kp = 2 * kPi / 0.04;  // wavelengths 0.05 deg lon, 0.04 deg lat
  double operator()(double lon, double lat) const {
    return Z0 + A * std::sin(kl * (lon - L0)) + B * std::cos(kp * (lat - P0)) + C * (lat - P0);
  }
  double fll_max() const { return A * kl * kl; }
  double fpp_max() const { return B * kp * kp; }
};

TEST_F(terrain_raster, GridSampleBilinearIsExactOnAPlaneAndClampsAtTheEdges) {
  Grid g(4, 3, 100.0, 200.0, 10.0, 5.0);
  auto plane = [](double x, double y) { return 2.0 * x - 3.0 * y + 1.0; };
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) g.at(i, j) = static_cast<float>(plane(g.cx(i), g.cy(j)));
  // Between centres: exact for a plane (float storage only).
  for (double x : {105.0, 111.0, 127.5, 135.0})
    for (double y : {197.5, 193.0, 187.5}) EXPECT_NEAR(g.sample(x, y), plane(x, y), 1e-3) << x << " " << y;
  // Outer half cell: clamped to the edge cell's value.
  EXPECT_NEAR(g.sample(100.0, 197.5), g.at(0, 0), 1e-6);
  EXPECT_NEAR(g.sample(140.0, 185.0), g.at(3, 2), 1e-6);
  // Outside: NaN.
  EXPECT_TRUE(std::isnan(g.sample(99.9, 190.0)));
  EXPECT_TRUE(std::isnan(g.sample(120.0, 200.1)));
  EXPECT_TRUE(std::isnan(g.sample(140.1, 190.0)));
  // A nodata cell poisons the four-cell neighbourhoods it belongs to, and only those.
  g.at(1, 1) = Grid::nodata;
  EXPECT_TRUE(std::isnan(g.sample(g.cx(1) + 3.0, g.cy(1) + 1.0)));
  EXPECT_TRUE(std::isnan(g.sample(g.cx(0) + 3.0, g.cy(0) - 1.0)));
  EXPECT_FALSE(std::isnan(g.sample(g.cx(2) + 3.0, g.cy(1) - 1.0)));
}

TEST_F(terrain_raster, UtmZoneAndCrsName) {
  EXPECT_EQ(utm_crs_for(-84.25, 36.59), "EPSG:32616");
  EXPECT_EQ(utm_crs_for(10.1, 46.05), "EPSG:32632");
  EXPECT_EQ(utm_crs_for(-180.0, -10.0), "EPSG:32701");
  EXPECT_EQ(utm_crs_for(179.99, 5.0), "EPSG:32660");
  EXPECT_EQ(utm_crs_for(174.8, -41.3), "EPSG:32760");
  EXPECT_EQ(crs_name(wkt_of("EPSG:32616")), "WGS 84 / UTM zone 16N");
  EXPECT_EQ(crs_name(""), "");
  EXPECT_EQ(crs_name("not a crs"), "");
}

// Geographic GeoTIFF of the analytic surface -> load_dem to UTM at 30 m -> compare with the surface.
TEST_F(terrain_raster, GeographicSurfaceReprojectsToUtmWithinTheBilinearBound) {
  const Surface f;
  const double h = 0.0005;  // source spacing in degrees (~39 m in lon, ~56 m in lat: coarser than 30 m)
  const int snx = 400, sny = 300;
  const double lon0 = 10.0, lat_n = 46.15;  // west and north edges
  std::vector<float> v(static_cast<size_t>(snx) * sny);
  for (int j = 0; j < sny; ++j)
    for (int i = 0; i < snx; ++i)
      v[size_t(j) * snx + i] = static_cast<float>(f(lon0 + (i + 0.5) * h, lat_n - (j + 0.5) * h));
  const double gt[6] = {lon0, h, 0, lat_n, 0, -h};
  const fs::path src = dir / "surface_4326.tif";
  write_test_tiff(src, snx, sny, gt, "EPSG:4326", v);

  const double res = 30.0;
  const Grid g = load_dem(src.string(), DemOptions{"", res});
  EXPECT_EQ(epsg_code_of(g.crs_wkt), "32632");
  EXPECT_EQ(crs_name(g.crs_wkt), "WGS 84 / UTM zone 32N");
  EXPECT_NEAR(g.dx, res, 1e-9);
  EXPECT_NEAR(g.dy, res, 1e-9);

  // Metres per degree on the UTM grid, smallest over the area (largest second derivative per metre):
  // measured from the projection itself at the corners.
  Transformer to_utm("EPSG:4326", "EPSG:32632");
  double m_lon = std::numeric_limits<double>::infinity(), m_lat = m_lon;
  for (double lon : {lon0, lon0 + snx * h})
    for (double lat : {lat_n, lat_n - sny * h}) {
      const double d = 1e-4;
      double xa = lon, ya = lat, xb = lon + d, yb = lat, xc = lon, yc = lat + d;
      to_utm(xa, ya);
      to_utm(xb, yb);
      to_utm(xc, yc);
      m_lon = std::min(m_lon, std::hypot(xb - xa, yb - ya) / d);
      m_lat = std::min(m_lat, std::hypot(xc - xa, yc - ya) / d);
    }

  // Stage 1 (GDAL's warp, bilinear between source centres at each target centre, exact transform):
  //   |e1| <= h^2/8 (max|f_ll| + max|f_pp|)                       [Ix Iy f - f = (Ix f - f) + Ix(Iy f - f)]
  // Stage 2 (Grid::sample between target centres, spacing H): the surface in metres F = f o T^-1 has, along
  // any unit direction of a conformal map, |F_uu| <= max(|f_ll| / m_lon^2, |f_pp| / m_lat^2), so
  //   |e2| <= H^2/8 (|F_xx| + |F_yy|) <= H^2/8 * 2 max(...);   composed: |sample - f| <= e1 + e2.
  // Slack: Float32 storage (~6e-5 m at 1 km) and the projection's own curvature (~1e-5 m here): 1 mm.
  const double e1 = h * h / 8.0 * (f.fll_max() + f.fpp_max());
  const double e2 =
      res * res / 8.0 * 2.0 * std::max(f.fll_max() / (m_lon * m_lon), f.fpp_max() / (m_lat * m_lat));
  const double slack = 1e-3;

  // Only where the four source centres around a point exist (1.5 source cells inside the edges).
  auto inside = [&](double lon, double lat) {
    return lon > lon0 + 1.5 * h && lon < lon0 + (snx - 1.5) * h && lat < lat_n - 1.5 * h && lat > lat_n - (sny - 1.5) * h;
  };
  Transformer to_geo("EPSG:32632", "EPSG:4326");
  double max_centre = 0, max_sampled = 0;
  int n_centre = 0, n_sampled = 0;
  for (int j = 0; j < g.ny; j += 3)
    for (int i = 0; i < g.nx; i += 3) {
      double lon = g.cx(i), lat = g.cy(j);
      to_geo(lon, lat);
      if (!inside(lon, lat)) continue;
      ASSERT_FALSE(std::isnan(g.at(i, j))) << i << " " << j;
      max_centre = std::max(max_centre, std::abs(g.at(i, j) - f(lon, lat)));
      ++n_centre;
    }
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> ux(g.x0, g.x1()), uy(g.y1(), g.y0);
  for (int k = 0; k < 40000; ++k) {
    const double x = ux(rng), y = uy(rng);
    double lon = x, lat = y;
    to_geo(lon, lat);
    // Stage 2 also needs the target centres around the point to be inside the source.
    if (!inside(lon, lat) || lon < lon0 + 3 * h || lon > lon0 + (snx - 3) * h || lat > lat_n - 3 * h ||
        lat < lat_n - (sny - 3) * h)
      continue;
    const double s = g.sample(x, y);
    ASSERT_FALSE(std::isnan(s));
    max_sampled = std::max(max_sampled, std::abs(s - f(lon, lat)));
    ++n_sampled;
  }
  std::printf("[ measured ] cell centres: n=%d max|err|=%.4f m, bound e1=%.4f m\n", n_centre, max_centre, e1);
  std::printf("[ measured ] random points: n=%d max|err|=%.4f m, bound e1+e2=%.4f m (e2=%.4f)\n", n_sampled,
              max_sampled, e1 + e2, e2);
  RecordProperty("max_err_centres_m", std::to_string(max_centre));
  RecordProperty("bound_centres_m", std::to_string(e1));
  RecordProperty("max_err_sampled_m", std::to_string(max_sampled));
  RecordProperty("bound_sampled_m", std::to_string(e1 + e2));
  EXPECT_GT(n_centre, 20000);
  EXPECT_GT(n_sampled, 20000);
  EXPECT_LE(max_centre, e1 + slack);
  EXPECT_LE(max_sampled, e1 + e2 + slack);
  // And the bound is not vacuous: the relief is ~1000 m, the bound well under a metre.
  EXPECT_LT(e1 + e2, 0.5);
}

TEST_F(terrain_raster, JacksboroVrtLoadsAsUtm16NAt30m) {
  const std::string vrt = std::string(RUNOUT_SOURCE_DIR) + "/scenarios/dem/jacksboro_fault_dem.vrt";
  ASSERT_TRUE(fs::exists(vrt));
  const Grid g = load_dem(vrt, DemOptions{"", 30.0});
  EXPECT_EQ(epsg_code_of(g.crs_wkt), "32616");
  EXPECT_EQ(crs_name(g.crs_wkt), "WGS 84 / UTM zone 16N");
  EXPECT_NEAR(g.dx, 30.0, 1e-9);
  EXPECT_NEAR(g.dy, 30.0, 1e-9);
  EXPECT_NEAR(g.nx, 1033, 2);
  EXPECT_NEAR(g.ny, 1088, 2);

  // Extent: the UTM bounding box of the source footprint (edges densified), within two cells.
  Transformer to_utm("EPSG:4269", "EPSG:32616");
  const double w = -84.41375, e = -84.07791666666667, n = 36.73291666666667, s = 36.44625;
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (int k = 0; k <= 200; ++k) {
    const double t = k / 200.0;
    const double pts[4][2] = {{w + t * (e - w), n}, {w + t * (e - w), s}, {w, s + t * (n - s)}, {e, s + t * (n - s)}};
    for (const auto& p : pts) {
      double x = p[0], y = p[1];
      to_utm(x, y);
      xmin = std::min(xmin, x), xmax = std::max(xmax, x), ymin = std::min(ymin, y), ymax = std::max(ymax, y);
    }
  }
  EXPECT_NEAR(g.x0, xmin, 60.0);
  EXPECT_NEAR(g.x1(), xmax, 60.0);
  EXPECT_NEAR(g.y0, ymax, 60.0);
  EXPECT_NEAR(g.y1(), ymin, 60.0);

  // Elevations: bilinear weights are convex, so the result stays inside the source range 236..1076 m.
  float lo = 1e9f, hi = -1e9f;
  size_t valid = 0;
  for (float v : g.values)
    if (!std::isnan(v)) lo = std::min(lo, v), hi = std::max(hi, v), ++valid;
  EXPECT_GE(lo, 236.0f - 1e-3f);
  EXPECT_LE(hi, 1076.0f + 1e-3f);
  EXPECT_GT(hi - lo, 700.0f);  // the relief is really there
  // The rotated footprint leaves NaN corners, but most of the box is data.
  EXPECT_GT(static_cast<double>(valid) / g.values.size(), 0.9);

  // Placement: at source cell centres, the warped DEM agrees with the source within the local relief.
  GDALDatasetH src = GDALOpenEx(vrt.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
  ASSERT_NE(src, nullptr);
  std::vector<float> sv(403 * 344);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(src, 1), GF_Read, 0, 0, 403, 344, sv.data(), 403, 344, GDT_Float32, 0, 0),
            CE_None);
  GDALClose(src);
  const double d = 1.0 / 1200.0;
  int checked = 0;
  for (int sj = 5; sj < 344 - 5; sj += 17)
    for (int si = 5; si < 403 - 5; si += 19) {
      double x = w + (si + 0.5) * d, y = n - (sj + 0.5) * d;
      to_utm(x, y);
      const double z = g.sample(x, y);
      ASSERT_FALSE(std::isnan(z));
      float nlo = 1e9f, nhi = -1e9f;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          const float v = sv[size_t(sj + dj) * 403 + si + di];
          nlo = std::min(nlo, v), nhi = std::max(nhi, v);
        }
      EXPECT_GE(z, nlo - 1e-3) << si << " " << sj;
      EXPECT_LE(z, nhi + 1e-3) << si << " " << sj;
      ++checked;
    }
  EXPECT_GT(checked, 300);
}

TEST_F(terrain_raster, ProjectedDemKeepsItsGridAndFlipsSouthUp) {
  // 5 x 4 in UTM 32N with a south-up geotransform (row 0 is the south edge).
  const int nx = 5, ny = 4;
  std::vector<float> v(nx * ny);
  for (int r = 0; r < ny; ++r)
    for (int i = 0; i < nx; ++i) v[r * nx + i] = static_cast<float>(100 * r + i);
  const double gt[6] = {500000.0, 10.0, 0, 5100000.0, 0, 10.0};  // y grows with the row
  const fs::path p = dir / "south_up.tif";
  write_test_tiff(p, nx, ny, gt, "EPSG:32632", v);
  const Grid g = load_dem(p.string());
  ASSERT_EQ(g.nx, nx);
  ASSERT_EQ(g.ny, ny);
  EXPECT_DOUBLE_EQ(g.x0, 500000.0);
  EXPECT_DOUBLE_EQ(g.y0, 5100040.0);  // north edge
  EXPECT_DOUBLE_EQ(g.dx, 10.0);
  EXPECT_DOUBLE_EQ(g.dy, 10.0);
  EXPECT_EQ(epsg_code_of(g.crs_wkt), "32632");
  // Grid row 0 is north = file row ny-1.
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) EXPECT_EQ(g.at(i, j), 100 * (ny - 1 - j) + i);

  // Asking for 20 m resamples in the same CRS.
  const Grid c = load_dem(p.string(), DemOptions{"", 20.0});
  EXPECT_NEAR(c.dx, 20.0, 1e-9);
  EXPECT_NEAR(c.dy, 20.0, 1e-9);
  EXPECT_EQ(epsg_code_of(c.crs_wkt), "32632");
  EXPECT_NEAR(c.x0, 500000.0, 1e-6);
  EXPECT_NEAR(c.y0, 5100040.0, 1e-6);
  EXPECT_EQ(c.nx, 3);  // 50 m / 20 m, rounded
  EXPECT_EQ(c.ny, 2);

  // Naming the file's own CRS as the target is not a reprojection: same grid, same values.
  const Grid same = load_dem(p.string(), DemOptions{"EPSG:32632", 0.0});
  EXPECT_EQ(same.nx, nx);
  EXPECT_EQ(same.ny, ny);
  EXPECT_EQ(same.values, g.values);
}

TEST_F(terrain_raster, NonMetreProjectedCrsNeedsATarget) {
  // NAD83 / North Carolina (ftUS).
  const int nx = 6, ny = 6;
  std::vector<float> v(nx * ny, 300.0f);
  const double gt[6] = {2000000.0, 100.0, 0, 700000.0, 0, -100.0};
  const fs::path p = dir / "feet.tif";
  write_test_tiff(p, nx, ny, gt, "EPSG:2264", v);
  try {
    load_dem(p.string());
    FAIL() << "expected TerrainError";
  } catch (const TerrainError& e) {
    EXPECT_EQ(e.field, "terrain.dem");
    EXPECT_NE(std::string(e.what()).find("foot"), std::string::npos) << e.what();
  }
  // A target that is not a usable metre CRS is the CRS field's fault.
  for (const char* bad : {"EPSG:4326", "not a crs at all", "EPSG:2264"}) {
    try {
      load_dem(p.string(), DemOptions{bad, 0.0});
      ADD_FAILURE() << "expected TerrainError for target " << bad;
    } catch (const TerrainError& e) {
      EXPECT_EQ(e.field, "terrain.crs") << e.what();
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  const Grid g = load_dem(p.string(), DemOptions{"EPSG:32617", 10.0});
  EXPECT_EQ(epsg_code_of(g.crs_wkt), "32617");
  EXPECT_NEAR(g.dx, 10.0, 1e-9);
  size_t valid = 0;
  for (float x : g.values)
    if (!std::isnan(x)) {
      ++valid;
      EXPECT_NEAR(x, 300.0f, 1e-3f);
    }
  EXPECT_GT(valid, 0u);
}

TEST_F(terrain_raster, GeoTiffRoundTrip) {
  Grid g(7, 5, 734000.0, 4068000.0, 30.0, 30.0, wkt_of("EPSG:32616"));
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) g.at(i, j) = 250.0f + 1.25f * i - 3.5f * j;
  g.at(2, 3) = Grid::nodata;
  const fs::path out = dir / "sub" / "dir" / "dem.tif";  // parent directories are created
  write_geotiff(out.string(), g);
  ASSERT_TRUE(fs::exists(out));
  EXPECT_EQ(listing(), (std::set<std::string>{"sub", "sub/dir", "sub/dir/dem.tif"}));  // no .tmp left

  GDALDatasetH ds = GDALOpenEx(out.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
  ASSERT_NE(ds, nullptr);
  EXPECT_EQ(GDALGetRasterXSize(ds), 7);
  EXPECT_EQ(GDALGetRasterYSize(ds), 5);
  EXPECT_EQ(GDALGetRasterCount(ds), 1);
  double gt[6];
  ASSERT_EQ(GDALGetGeoTransform(ds, gt), CE_None);
  EXPECT_DOUBLE_EQ(gt[0], g.x0);
  EXPECT_DOUBLE_EQ(gt[1], 30.0);
  EXPECT_DOUBLE_EQ(gt[2], 0.0);
  EXPECT_DOUBLE_EQ(gt[3], g.y0);
  EXPECT_DOUBLE_EQ(gt[4], 0.0);
  EXPECT_DOUBLE_EQ(gt[5], -30.0);
  OGRSpatialReference want;
  want.importFromWkt(g.crs_wkt.c_str());
  ASSERT_NE(GDALGetSpatialRef(ds), nullptr);
  EXPECT_TRUE(OGRSpatialReference::FromHandle(GDALGetSpatialRef(ds))->IsSame(&want));
  GDALRasterBandH b = GDALGetRasterBand(ds, 1);
  EXPECT_EQ(GDALGetRasterDataType(b), GDT_Float32);
  int has = 0;
  EXPECT_TRUE(std::isnan(GDALGetRasterNoDataValue(b, &has)));
  EXPECT_TRUE(has);
  const char* comp = GDALGetMetadataItem(ds, "COMPRESSION", "IMAGE_STRUCTURE");
  ASSERT_NE(comp, nullptr);
  EXPECT_STREQ(comp, "DEFLATE");
  std::vector<float> v(35);
  ASSERT_EQ(GDALRasterIO(b, GF_Read, 0, 0, 7, 5, v.data(), 7, 5, GDT_Float32, 0, 0), CE_None);
  GDALClose(ds);
  for (size_t k = 0; k < v.size(); ++k) {
    if (std::isnan(g.values[k]))
      EXPECT_TRUE(std::isnan(v[k]));
    else
      EXPECT_EQ(v[k], g.values[k]);
  }

  // load_dem reads it back unchanged (projected metre CRS, native resolution: no warp).
  const Grid r = load_dem(out.string());
  EXPECT_EQ(r.nx, g.nx);
  EXPECT_EQ(r.ny, g.ny);
  EXPECT_DOUBLE_EQ(r.x0, g.x0);
  EXPECT_DOUBLE_EQ(r.y0, g.y0);
  for (size_t k = 0; k < v.size(); ++k)
    if (!std::isnan(g.values[k])) {
      EXPECT_EQ(r.values[k], g.values[k]);
    }
  EXPECT_TRUE(std::isnan(r.at(2, 3)));

  // The command-line gdalinfo accepts it too.
  if (fs::exists("/usr/bin/gdalinfo")) {
    const std::string cmd = "/usr/bin/gdalinfo '" + out.string() + "' > /dev/null 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0);
  }
  EXPECT_THROW(write_geotiff((dir / "bad.tif").string(), Grid()), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "bad.tif"));
}

TEST_F(terrain_raster, DepthMapPngShowsTheFlowInBlue) {
  const int nx = 120, ny = 80;
  Grid terrain(nx, ny, 500000.0, 5000000.0, 10.0, 10.0, wkt_of("EPSG:32632"));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      terrain.at(i, j) = static_cast<float>(300.0 + 40.0 * std::sin(i / 9.0) * std::cos(j / 11.0) + 0.8 * j);
  terrain.at(nx - 1, ny - 1) = Grid::nodata;
  Grid depth = terrain.like(0.0f);
  for (int j = 30; j < 50; ++j)
    for (int i = 20; i < 40; ++i) depth.at(i, j) = 3.0f;
  depth.at(30, 40) = 6.0f;  // the maximum
  MapOverlay outline;
  outline.lines.push_back({{terrain.cx(60), terrain.cy(10)}, {terrain.cx(100), terrain.cy(10)}});  // horizontal line
  const fs::path out = dir / "maps" / "depth.png";
  write_depth_map_png(out.string(), terrain, depth, 0.1, {outline});
  ASSERT_TRUE(fs::exists(out));
  EXPECT_EQ(listing(), (std::set<std::string>{"maps", "maps/depth.png"}));  // no .tmp, no .aux.xml

  const int f = depth_map_png_scale(nx, ny);
  EXPECT_GE(f, 2);
  EXPECT_GE(nx * f, 500);  // enlarged so a person can see it
  GDALDatasetH ds = GDALOpenEx(out.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
  ASSERT_NE(ds, nullptr);
  EXPECT_STREQ(GDALGetDriverShortName(GDALGetDatasetDriver(ds)), "PNG");
  ASSERT_EQ(GDALGetRasterCount(ds), 3);
  const int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds);
  EXPECT_EQ(w, nx * f);
  EXPECT_EQ(h, ny * f);
  std::vector<unsigned char> rgb[3];
  for (int c = 0; c < 3; ++c) {
    GDALRasterBandH b = GDALGetRasterBand(ds, c + 1);
    EXPECT_EQ(GDALGetRasterDataType(b), GDT_Byte);
    rgb[c].resize(size_t(w) * h);
    ASSERT_EQ(GDALRasterIO(b, GF_Read, 0, 0, w, h, rgb[c].data(), w, h, GDT_Byte, 0, 0), CE_None);
  }
  GDALClose(ds);
  auto px = [&](int i, int j, int c) { return static_cast<int>(rgb[c][size_t(j * f + f / 2) * w + i * f + f / 2]); };
  auto blueness = [&](int i, int j) { return px(i, j, 2) - (px(i, j, 0) + px(i, j, 1)) / 2; };
  // Inside the flow: blue; far from it: grey (r = g = b).
  EXPECT_GT(blueness(30, 40), 60);
  EXPECT_GT(blueness(25, 35), 40);
  for (auto [i, j] : {std::pair{90, 60}, std::pair{5, 5}, std::pair{70, 30}}) {
    EXPECT_EQ(px(i, j, 0), px(i, j, 1)) << i << " " << j;
    EXPECT_EQ(px(i, j, 1), px(i, j, 2)) << i << " " << j;
    EXPECT_GT(blueness(30, 40), blueness(i, j) + 60);
  }
  // Deeper is darker: the 6 m cell is darker than the 3 m cells.
  EXPECT_LT(px(30, 40, 0) + px(30, 40, 1), px(25, 35, 0) + px(25, 35, 1));
  // The overlay line is drawn in its colour.
  EXPECT_EQ(px(80, 10, 0), 200);
  EXPECT_EQ(px(80, 10, 1), 30);
  EXPECT_EQ(px(80, 10, 2), 30);
  // The hillshade has texture (not a flat grey).
  int gmin = 255, gmax = 0;
  for (int i = 60; i < 110; ++i) gmin = std::min(gmin, px(i, 70, 0)), gmax = std::max(gmax, px(i, 70, 0));
  EXPECT_GT(gmax - gmin, 30);

  EXPECT_THROW(write_depth_map_png((dir / "x.png").string(), terrain, Grid(3, 3, 0, 0, 1, 1), 0.1),
               std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

// Each bad input: TerrainError on "terrain.dem" naming the problem, and no file appears next to it.
TEST_F(terrain_raster, BadInputsAreRefusedWithoutWritingAnything) {
  auto expect_error = [&](const std::string& path, std::vector<std::string> needles) {
    const auto before = listing();
    try {
      load_dem(path);
      ADD_FAILURE() << "load_dem(" << path << ") did not throw";
    } catch (const TerrainError& e) {
      EXPECT_EQ(e.field, "terrain.dem");
      for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
      std::printf("[ message  ] %s\n", e.what());
    }
    EXPECT_EQ(listing(), before) << "load_dem wrote something for " << path;
  };

  const std::string missing = (dir / "does_not_exist.tif").string();
  expect_error(missing, {"cannot open", missing});

  const fs::path text = dir / "notes.txt";
  std::ofstream(text) << "This is a field note, not a raster.\nElevation unknown.\n";
  expect_error(text.string(), {"cannot open", text.string(), "not recognized"});

  const double gt[6] = {500000.0, 10.0, 0, 5000000.0, 0, -10.0};
  const fs::path nocrs = dir / "no_crs.tif";
  write_test_tiff(nocrs, 4, 4, gt, "", std::vector<float>(16, 100.0f));
  expect_error(nocrs.string(), {"no coordinate reference system"});

  const double nd = -9999.0;
  const fs::path empty = dir / "all_nodata.tif";
  write_test_tiff(empty, 4, 4, gt, "EPSG:32632", std::vector<float>(16, -9999.0f), &nd);
  expect_error(empty.string(), {"only nodata"});
  // The same in geographic coordinates goes through the warp and is refused just the same.
  const double ggt[6] = {10.0, 0.001, 0, 46.0, 0, -0.001};
  const fs::path empty_geo = dir / "all_nodata_geo.tif";
  write_test_tiff(empty_geo, 4, 4, ggt, "EPSG:4326", std::vector<float>(16, -9999.0f), &nd);
  expect_error(empty_geo.string(), {"only nodata"});

  const double rot[6] = {500000.0, 10.0, 1.0, 5000000.0, 1.0, -10.0};
  const fs::path rotated = dir / "rotated.tif";
  write_test_tiff(rotated, 4, 4, rot, "EPSG:32632", std::vector<float>(16, 100.0f));
  expect_error(rotated.string(), {"rotated"});
}

// Several threads loading and writing at once (GDAL registration happens once; error state is per thread).
// load_dem keeps the grids it made by the content they came from: the same DEM again is the same grid, from the
// keep; a file rewritten in place (same name and size, other values), directly or as a VRT's source, is read
// afresh; other options make another grid.
TEST_F(terrain_raster, KeptGridsFollowTheFilesContent) {
  const int nx = 6, ny = 5;
  std::vector<float> v(nx * ny);
  for (int k = 0; k < nx * ny; ++k) v[k] = 300.0f + static_cast<float>(k);
  const double gt[6] = {500000.0, 10.0, 0, 5100000.0, 0, -10.0};
  const fs::path tif = dir / "dem.tif", vrt = dir / "dem.vrt";
  write_test_tiff(tif, nx, ny, gt, "EPSG:32632", v);
  GDALDatasetH src = GDALOpen(tif.c_str(), GA_ReadOnly);
  ASSERT_NE(src, nullptr);
  GDALClose(GDALCreateCopy(GDALGetDriverByName("VRT"), vrt.c_str(), src, FALSE, nullptr, nullptr, nullptr));
  GDALClose(src);

  const DemCacheStats s0 = dem_cache_stats();
  const Grid a = load_dem(tif.string()), b = load_dem(tif.string());
  const DemCacheStats s1 = dem_cache_stats();
  EXPECT_EQ(s1.misses - s0.misses, 1);
  EXPECT_EQ(s1.hits - s0.hits, 1);
  EXPECT_EQ(b.values, a.values);
  EXPECT_EQ(b.crs_wkt, a.crs_wkt);
  EXPECT_EQ(b.x0, a.x0);
  EXPECT_EQ(b.dx, a.dx);
  EXPECT_EQ(load_dem(vrt.string()).values, v);

  for (float& x : v) x += 1.0f;
  write_test_tiff(tif, nx, ny, gt, "EPSG:32632", v);
  EXPECT_EQ(load_dem(tif.string()).values, v);
  EXPECT_EQ(load_dem(vrt.string()).values, v);
  EXPECT_EQ(load_dem(tif.string(), DemOptions{"", 20.0}).nx, 3);
  EXPECT_EQ(dem_cache_stats().misses - s1.misses, 4);  // the VRT once, both rewritten, the 20 m grid
}

TEST_F(terrain_raster, ConcurrentLoadsAgree) {
  const int nx = 60, ny = 50;
  std::vector<float> v(nx * ny);
  for (int k = 0; k < nx * ny; ++k) v[k] = 100.0f + 0.5f * (k % nx) + 0.25f * (k / nx);
  const double gt[6] = {7.0, 0.001, 0, 47.0, 0, -0.001};
  const fs::path src = dir / "geo.tif";
  write_test_tiff(src, nx, ny, gt, "EPSG:4326", v);
  const Grid ref = load_dem(src.string(), DemOptions{"", 25.0});
  std::vector<Grid> got(4);
  std::vector<std::string> errors(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      try {
        got[t] = load_dem(src.string(), DemOptions{"", 25.0});
        write_geotiff((dir / ("out" + std::to_string(t) + ".tif")).string(), got[t]);
        load_dem((dir / "missing.tif").string());
      } catch (const TerrainError& e) {
        errors[t] = e.what();
      } catch (const std::exception& e) {
        errors[t] = std::string("unexpected: ") + e.what();
      }
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) {
    EXPECT_EQ(got[t].nx, ref.nx);
    EXPECT_EQ(got[t].ny, ref.ny);
    EXPECT_EQ(std::memcmp(got[t].values.data(), ref.values.data(), ref.values.size() * sizeof(float)), 0);
    EXPECT_NE(errors[t].find("missing.tif: No such file"), std::string::npos) << errors[t];
    EXPECT_TRUE(fs::exists(dir / ("out" + std::to_string(t) + ".tif")));
  }
}

}  // namespace
