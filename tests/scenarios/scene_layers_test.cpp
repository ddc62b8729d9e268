// Scenes whose geometry lives in vector files ({"layer": ..., "name": ..., "where": ...}): the flume's layouts
// from a GeoPackage give exactly the particles of their inline coordinates, also from a layer in geographic
// coordinates; refusals name the scene field. The shipped catchment GeoPackage: catchment_layers_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gdal_priv.h>
#include <nlohmann/json.hpp>
#include <ogrsf_frmts.h>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/scene_map.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;

json read_json(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-layers-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// Writes the scene's geometry into one GeoPackage (a layer per kind, a "name" field), in `crs` (the points
// transformed from the flume's EPSG:32632), and returns the scene with layer references in its place.
class LayerWriter {
 public:
  LayerWriter(const fs::path& file, const std::string& crs) : file_(file) {
    GDALAllRegister();
    ds_ = GetGDALDriverManager()->GetDriverByName("GPKG")->Create(file.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
    src_.SetFromUserInput("EPSG:32632");
    dst_.SetFromUserInput(crs.c_str());
    src_.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    dst_.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    ct_.reset(OGRCreateCoordinateTransformation(&src_, &dst_));
  }
  ~LayerWriter() { GDALClose(ds_); }

  // Adds the points as a feature of `layer` and returns the reference to it.
  json add(const std::string& layer, const std::string& name, const json& points, bool polygon) {
    OGRLayer* l = ds_->GetLayerByName(layer.c_str());
    if (!l) {
      l = ds_->CreateLayer(layer.c_str(), &dst_, polygon ? wkbPolygon : wkbLineString, nullptr);
      OGRFieldDefn f("name", OFTString);
      l->CreateField(&f);
    }
    OGRLineString line;
    OGRLinearRing ring;
    for (const auto& p : points) {
      double x = p[0].get<double>(), y = p[1].get<double>();
      ct_->Transform(1, &x, &y);
      polygon ? ring.addPoint(x, y) : line.addPoint(x, y);
    }
    OGRFeature feature(l->GetLayerDefn());
    feature.SetField("name", name.c_str());
    if (polygon) {
      ring.closeRings();
      OGRPolygon poly;
      poly.addRing(&ring);
      feature.SetGeometry(&poly);
    } else {
      feature.SetGeometry(&line);
    }
    EXPECT_EQ(l->CreateFeature(&feature), OGRERR_NONE);
    return {{"layer", file_.filename().string()}, {"name", layer}, {"where", "name = '" + name + "'"}};
  }

 private:
  fs::path file_;
  GDALDataset* ds_ = nullptr;
  OGRSpatialReference src_, dst_;
  std::unique_ptr<OGRCoordinateTransformation> ct_;
};

// The flume scene (absolute DEM path). `shift` moves the release, structures and zones by that much east and
// north and pulls the corridor in by it: the flume's vertices sit on particle columns' centres or edges
// (0.45 m at dp 2 cm; the corridor on the DEM's edges, where its box's last column starts), where a nanometre
// decides a column either way (measured: the corridor's round trip through EPSG:4326 added a row of 58
// boundary particles); 3.7 mm away from them no rounding can.
// `layout` keeps those candidate structures (the flume's candidates overlap: a layout is C0-C7's choice).
json flume_inline(const std::vector<std::string>& layout, double shift = 0.0) {
  json s = read_json(kSource / "scenarios/flume/flume.json");
  s["terrain"]["dem"] = (kSource / "scenarios/flume/flume_dem.asc").string();
  json kept = json::array();
  for (const auto& st : s["structures"])
    if (std::find(layout.begin(), layout.end(), st["name"].get<std::string>()) != layout.end()) kept.push_back(st);
  s["structures"] = kept;
  json monitors = json::array();
  for (const auto& m : s["monitors"])
    if (m["type"] == "section" || std::find(layout.begin(), layout.end(), m.value("structure", "")) != layout.end())
      monitors.push_back(m);
  s["monitors"] = monitors;
  auto move = [&](json& points) {
    for (auto& p : points) p = {p[0].get<double>() + shift, p[1].get<double>() + shift};
  };
  if (shift != 0.0) {  // the corridor's edges are the DEM's: pulled in by `shift` off the lattice lines
    s["terrain"]["corridor"]["polygon"] = {{500000.0 + shift, 5000000.0 + shift}, {500006.0 - shift, 5000000.0 + shift},
                                           {500006.0 - shift, 5000001.2 - shift}, {500000.0 + shift, 5000001.2 - shift}};
  }
  move(s["release"]["polygon"]);
  for (auto& st : s["structures"]) move(st.contains("polygon") ? st["polygon"] : st["axis"]);
  for (auto& z : s["protected_zones"]) move(z["polygon"]);
  return s;
}

// The same with every geometry moved into layers.gpkg in `crs`.
json flume_from_layers(const fs::path& dir, const std::string& crs, const std::vector<std::string>& layout,
                       double shift = 0.0) {
  json s = flume_inline(layout, shift);
  {
    LayerWriter w(dir / "layers.gpkg", crs);
    s["terrain"]["corridor"]["polygon"] = w.add("corridor", "corridor", s["terrain"]["corridor"]["polygon"], true);
    s["release"]["polygon"] = w.add("release", "release", s["release"]["polygon"], true);
    for (auto& st : s["structures"]) {
      const bool area = st.contains("polygon");
      const std::string key = area ? "polygon" : "axis";
      st[key] = w.add(area ? "areas" : "dams", st["name"], st[key], area);
    }
    for (auto& z : s["protected_zones"]) z["polygon"] = w.add("zones", z["name"], z["polygon"], true);
    for (auto& m : s["monitors"])
      if (m["type"] == "section") m["line"] = w.add("sections", m["name"], m["line"], false);
  }
  return s;
}

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

Scene parse_at(json s, double dp, const fs::path& dir) {
  s["dp"] = dp;
  return parse_scene(s.dump(), dir);
}

}  // namespace

TEST(SceneLayers, FlumeFromAGeoPackageInItsOwnCrsBuildsTheSameParticles) {
  // C6 (a deposition area and a check dam) and C7 (a deposition area and a retention basin).
  for (const std::vector<std::string> layout : {std::vector<std::string>{"FD_P1", "CD_P2"}, {"FD_P1", "RB1_P2"}}) {
    TempDir tmp;
    const Scene a = parse_at(flume_inline(layout), 0.02, tmp.path);
    const Scene b = parse_at(flume_from_layers(tmp.path, "EPSG:32632", layout), 0.02, tmp.path);
    EXPECT_GT(std::get<SceneSetup<3>>(a.setup).fluid.size(), 100u);
    ASSERT_EQ(a.terrain->structures.size(), 2u);
    expect_same_scene(a, b, 0.0);
  }
}

TEST(SceneLayers, FlumeFromAGeographicGeoPackageBuildsTheSameParticles) {
  // EPSG:4326 there and back moves a vertex by nanometres (a double holds a degree to ~1e-11 m; PROJ's
  // transverse Mercator round trip adds a few nanometres). With the vertices millimetres from any
  // column centre or edge, no column may change: the particles must be identical; the sections' points
  // (not shifted) agree to 1 micrometre.
  // RB1_P2's open edge is pinned to its upstream edge (3): by default the basin opens on the edge whose
  // midpoint is highest, and its two lateral edges lie on the flume's symmetric banks at the same height, so
  // a nanometre picks one or the other (measured here: 50 wall particles and the flow normal (0, +1) against
  // (0, -1); the shipped C4, C5 and C7 open on a bank edge by that tie).
  for (const std::vector<std::string> layout : {std::vector<std::string>{"FD_P1", "CD_P2"}, {"FD_P1", "RB1_P2"}}) {
    TempDir tmp;
    json a_scene = flume_inline(layout, 0.0037), b_scene = flume_from_layers(tmp.path, "EPSG:4326", layout, 0.0037);
    for (json* s : {&a_scene, &b_scene})
      for (auto& st : (*s)["structures"])
        if (st["name"] == "RB1_P2") st["open_edges"] = {3};
    const Scene a = parse_at(a_scene, 0.02, tmp.path);
    const Scene b = parse_at(b_scene, 0.02, tmp.path);
    expect_same_scene(a, b, 1e-6);
  }
}

TEST(SceneLayers, MapGeometryReadsTheLayersAsTheRunDoes) {
  // scene_map (the service's map.json): a scene whose geometry is in layers draws what the inline scene draws.
  TempDir tmp;
  const std::vector<std::string> layout{"FD_P1", "CD_P2"};
  const SceneMap a = scene_map(flume_inline(layout).dump(), tmp.path);
  const SceneMap b = scene_map(flume_from_layers(tmp.path, "EPSG:32632", layout).dump(), tmp.path);
  ASSERT_EQ(a.structures.size(), 2u);
  ASSERT_EQ(b.structures.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(a.structures[k].name, b.structures[k].name);
    EXPECT_EQ(a.structures[k].points, b.structures[k].points);
    EXPECT_GE(b.structures[k].points.size(), 2u);
  }
  ASSERT_EQ(b.protected_zones.size(), a.protected_zones.size());
  for (size_t k = 0; k < a.protected_zones.size(); ++k) EXPECT_EQ(a.protected_zones[k].points, b.protected_zones[k].points);
  ASSERT_TRUE(a.release && b.release);
  EXPECT_EQ(a.release->points, b.release->points);
  ASSERT_EQ(a.sections.size(), b.sections.size());
  EXPECT_EQ(a.sections[0].points, b.sections[0].points);
}

TEST(SceneLayers, RefusalsNameTheSceneField) {
  TempDir tmp;
  const json base = flume_from_layers(tmp.path, "EPSG:32632", {"FD_P1", "CD_P2"});
  auto refused = [&](json s, const std::string& field, const std::string& words) {
    try {
      parse_at(std::move(s), 0.02, tmp.path);
      ADD_FAILURE() << "not refused: " << field;
    } catch (const SceneError& e) {
      EXPECT_EQ(e.field, field) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  json s = base;
  s["structures"][1]["axis"]["name"] = "walls";
  refused(s, "structures[1].axis", "no such layer");
  s = base;
  s["structures"][1]["axis"].erase("layer");
  refused(s, "structures[1].axis.layer", "missing");
  s = base;
  s["structures"][1]["axis"]["colour"] = "red";
  refused(s, "structures[1].axis.colour", "unknown field");
  s = base;
  s["release"]["polygon"]["layer"] = "nowhere.gpkg";
  refused(s, "release.polygon", "cannot open");
  s = base;
  s["protected_zones"][0]["polygon"]["where"] = "name = 'Nowhere'";
  refused(s, "protected_zones[0].polygon", "matches no feature");
  const fs::path dir2 = tmp.path / "second";
  fs::create_directories(dir2);
  s = flume_from_layers(dir2, "EPSG:32632", {"FD_P1", "RB1_P2"});
  s["structures"][0]["polygon"].erase("where");  // FD_P1 and RB1_P2 share the "areas" layer
  {
    try {
      parse_at(s, 0.02, dir2);
      ADD_FAILURE() << "not refused: two polygons for one structure";
    } catch (const SceneError& e) {
      EXPECT_EQ(e.field, "structures[0].polygon") << e.what();
      EXPECT_NE(std::string(e.what()).find("2 features match; this field takes one polygon"), std::string::npos) << e.what();
    }
  }
  s = base;
  s["monitors"][0]["line"] = s["structures"][0]["polygon"];  // a polygon where a line is meant
  refused(s, "monitors[0].line", "this field takes a LineString");
}
