// Class grids to polygons (GDALSieveFilter, then GDALPolygonize) in a GeoPackage: the inundated area and the
// intensity classes, with the CRS under its EPSG code and each layer's QGIS style in layer_styles.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>

#include <cpl_error.h>
#include <gdal.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout::terrain {
namespace {

namespace fs = std::filesystem;

struct Closer {
  void operator()(GDALDataset* d) const { GDALClose(GDALDataset::ToHandle(d)); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, Closer>;

std::string gdal_message() {
  const char* msg = CPLGetLastErrorMsg();
  return (msg && *msg) ? std::string(msg) : std::string("no details from GDAL");
}

void register_drivers() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("write_class_polygons: " + what + " ('" + path + "'): " + gdal_message());
}

// The class grid as a Byte raster in memory (its own mask: 0 is no class).
DatasetPtr class_raster(const Grid& g, const std::string& path) {
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  DatasetPtr ds(mem->Create("", g.nx, g.ny, 1, GDT_Byte, nullptr));
  if (!ds) fail(path, "cannot create an in-memory raster");
  double gt[6] = {g.x0, g.dx, 0.0, g.y0, 0.0, -g.dy};
  ds->SetGeoTransform(gt);
  std::vector<unsigned char> bytes(g.values.size());
  for (size_t k = 0; k < bytes.size(); ++k) {
    const float v = g.values[k];
    bytes[k] = (v >= 1.0f && v <= 255.0f) ? static_cast<unsigned char>(v) : 0;
  }
  if (ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, g.nx, g.ny, bytes.data(), g.nx, g.ny, GDT_Byte, 0, 0) != CE_None)
    fail(path, "cannot fill the in-memory raster");
  return ds;
}

// The grid's CRS as the GeoPackage should store it: by its EPSG definition where GDAL identifies the WKT as
// one (a DEM's .prj is often ESRI WKT without an authority, which the GPKG driver would store as a custom
// srs_id 100000 that QGIS cannot name), else the WKT as it is.
OGRSpatialReference layer_crs(const std::string& wkt) {
  OGRSpatialReference srs;
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  if (wkt.empty() || srs.importFromWkt(wkt.c_str()) != OGRERR_NONE) return srs;
  int code = 0;
  if (srs.AutoIdentifyEPSG() == OGRERR_NONE && srs.GetAuthorityCode(nullptr)) code = std::atoi(srs.GetAuthorityCode(nullptr));
  if (code <= 0) {  // AutoIdentifyEPSG knows UTM and geographic CRSs; PROJ's catalogue the rest (90 %: GDAL's default)
    if (OGRSpatialReference* best = srs.FindBestMatch(90, "EPSG")) {
      const char* auth = best->GetAuthorityName(nullptr);
      if (auth && std::string(auth) == "EPSG" && best->GetAuthorityCode(nullptr)) code = std::atoi(best->GetAuthorityCode(nullptr));
      best->Release();
    }
  }
  if (code > 0) {
    OGRSpatialReference epsg;
    epsg.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    if (epsg.importFromEPSG(code) == OGRERR_NONE) return epsg;
  }
  return srs;
}

void add_layer(GDALDataset& out, const ClassLayer& spec, const std::string& path) {
  if (!spec.classes) throw std::invalid_argument("write_class_polygons: layer '" + spec.name + "' has no grid");
  const Grid& g = *spec.classes;
  OGRSpatialReference srs = layer_crs(g.crs_wkt);
  OGRLayer* layer = out.CreateLayer(spec.name.c_str(), g.crs_wkt.empty() ? nullptr : &srs, wkbPolygon, nullptr);
  if (!layer) fail(path, "cannot create layer '" + spec.name + "'");
  for (const auto& [name, type] : {std::pair<const char*, OGRFieldType>{"class", OFTInteger}, {"label", OFTString},
                                   {"area_m2", OFTReal}}) {
    OGRFieldDefn f(name, type);
    if (layer->CreateField(&f) != OGRERR_NONE) fail(path, std::string("cannot add field ") + name);
  }
  DatasetPtr raster = class_raster(g, path);
  GDALRasterBandH band = GDALRasterBand::ToHandle(raster->GetRasterBand(1));
  // No mask: "no class" (0) is a region like the others, so a one-cell speck in the open merges into it (it
  // goes) and a one-cell hole into its class. 4-connected, as GDALPolygonize traces.
  if (GDALSieveFilter(band, nullptr, band, kPolygonSieveCells, 4, nullptr, nullptr, nullptr) != CE_None)
    fail(path, "sieving layer '" + spec.name + "' failed");
  if (GDALPolygonize(band, band, OGRLayer::ToHandle(layer), 0, nullptr, nullptr, nullptr) != CE_None)
    fail(path, "polygonizing layer '" + spec.name + "' failed");
  // Labels and areas, in a transaction (GeoPackage writes are slow one by one).
  out.StartTransaction();
  layer->ResetReading();
  std::vector<std::unique_ptr<OGRFeature>> features;
  for (auto& f : *layer) features.emplace_back(f.release());
  for (auto& f : features) {
    const int c = f->GetFieldAsInteger("class");
    if (c >= 1 && static_cast<size_t>(c) <= spec.labels.size()) f->SetField("label", spec.labels[c - 1].c_str());
    if (const OGRGeometry* geom = f->GetGeometryRef()) f->SetField("area_m2", geom->toPolygon()->get_Area());
    if (layer->SetFeature(f.get()) != OGRERR_NONE) fail(path, "cannot label a polygon");
  }
  out.CommitTransaction();
}

// The QGIS convention for styles kept in a GeoPackage (what QGIS writes with "Save as Default" into the
// file): a table layer_styles, one row per layer with its QML and useAsDefault = 1, which QGIS applies when the
// layer is loaded. Created through OGR so that it is registered in gpkg_contents as an attributes table.
OGRLayer* style_table(GDALDataset& out, const std::string& path) {
  if (OGRLayer* t = out.GetLayerByName("layer_styles")) return t;
  OGRLayer* t = out.CreateLayer("layer_styles", nullptr, wkbNone, nullptr);
  if (!t) fail(path, "cannot create the layer_styles table");
  const std::pair<const char*, OGRFieldType> fields[] = {
      {"f_table_catalog", OFTString}, {"f_table_schema", OFTString}, {"f_table_name", OFTString},
      {"f_geometry_column", OFTString}, {"styleName", OFTString},     {"styleQML", OFTString},
      {"styleSLD", OFTString},        {"useAsDefault", OFTInteger},  {"description", OFTString},
      {"owner", OFTString},           {"ui", OFTString},             {"update_time", OFTDateTime}};
  for (const auto& [name, type] : fields) {
    OGRFieldDefn f(name, type);
    if (std::string(name) == "useAsDefault") f.SetSubType(OFSTBoolean);
    if (t->CreateField(&f) != OGRERR_NONE) fail(path, std::string("cannot add field layer_styles.") + name);
  }
  return t;
}

// One row of layer_styles: the layer's QML, its default.
void add_style(GDALDataset& out, const std::string& layer, const std::string& qml, const std::string& description,
               const std::string& path) {
  OGRLayer* t = style_table(out, path);
  OGRFeature f(t->GetLayerDefn());
  f.SetField("f_table_catalog", "");
  f.SetField("f_table_schema", "");
  f.SetField("f_table_name", layer.c_str());
  f.SetField("f_geometry_column", out.GetLayerByName(layer.c_str())->GetGeometryColumn());
  f.SetField("styleName", layer.c_str());
  f.SetField("styleQML", qml.c_str());
  f.SetField("styleSLD", "");
  f.SetField("useAsDefault", 1);
  f.SetField("description", ("runout: " + description).c_str());
  f.SetField("owner", "");
  f.SetField("ui", "");
  if (t->CreateFeature(&f) != OGRERR_NONE) fail(path, "cannot store the style of layer '" + layer + "'");
}

void add_layer_styles(GDALDataset& out, const std::vector<ClassLayer>& layers, const std::string& path) {
  for (const auto& l : layers) {
    if (l.colours.empty()) continue;
    if (l.colours.size() != l.labels.size())
      throw std::invalid_argument("write_class_polygons: layer '" + l.name + "' has " + std::to_string(l.colours.size()) +
                                  " colours for " + std::to_string(l.labels.size()) + " classes");
    std::vector<StyleStop> categories;
    for (size_t k = 0; k < l.labels.size(); ++k) categories.push_back({static_cast<double>(k + 1), l.colours[k], l.labels[k]});
    add_style(out, l.name, vector_class_qml("class", categories), l.name + " coloured by class", path);
  }
}

// One layer of structures (lines or polygons) with their fields; nothing (false) when none is of this shape.
bool add_structure_layer(GDALDataset& out, const std::string& name, bool areas, const std::vector<StructureInfo>& all,
                         const std::string& crs_wkt, const std::vector<double>& retained,
                         const std::vector<double>& upstream, const std::string& path) {
  std::vector<size_t> which;
  for (size_t k = 0; k < all.size(); ++k)
    if (all[k].type->area == areas && all[k].outline.size() >= (areas ? 3u : 2u)) which.push_back(k);
  if (which.empty()) return false;
  OGRSpatialReference srs = layer_crs(crs_wkt);
  OGRLayer* layer = out.CreateLayer(name.c_str(), crs_wkt.empty() ? nullptr : &srs, areas ? wkbPolygon : wkbLineString, nullptr);
  if (!layer) fail(path, "cannot create layer '" + name + "'");
  std::vector<std::pair<std::string, OGRFieldType>> fields = {
      {"name", OFTString},           {"type", OFTString},           {"crest_elevation_m", OFTReal},
      {"wall_height_m", OFTReal},    {"storage_capacity_m3", OFTReal}, {"cut_volume_m3", OFTReal},
      {"fill_volume_m3", OFTReal},   {"retained_volume_m3", OFTReal}};
  if (!areas) fields.push_back({"upstream_volume_m3", OFTReal});
  if (areas) fields.push_back({"area_m2", OFTReal});
  for (const auto& [field, type] : fields) {
    OGRFieldDefn f(field.c_str(), type);
    if (layer->CreateField(&f) != OGRERR_NONE) fail(path, "cannot add field " + name + "." + field);
  }
  auto real = [](OGRFeature& f, const char* field, double v) {
    if (std::isfinite(v)) f.SetField(field, v);  // unknown stays null
  };
  out.StartTransaction();
  for (size_t k : which) {
    const StructureInfo& st = all[k];
    OGRFeature f(layer->GetLayerDefn());
    f.SetField("name", st.name.c_str());
    f.SetField("type", st.type->name.c_str());
    real(f, "crest_elevation_m", st.crest_elevation);
    real(f, "wall_height_m", st.wall_height_built);
    real(f, "storage_capacity_m3", st.storage_capacity);
    real(f, "cut_volume_m3", st.cut_volume);
    real(f, "fill_volume_m3", st.fill_volume);
    real(f, "retained_volume_m3", k < retained.size() ? retained[k] : NAN);
    OGRLineString line;
    for (const auto& p : st.outline) line.addPoint(p[0], p[1]);
    if (areas) {
      OGRLinearRing ring;
      ring.addSubLineString(&line);
      ring.closeRings();
      OGRPolygon polygon;
      polygon.addRing(&ring);
      real(f, "area_m2", polygon.get_Area());
      f.SetGeometry(&polygon);
    } else {
      real(f, "upstream_volume_m3", k < upstream.size() ? upstream[k] : NAN);
      f.SetGeometry(&line);
    }
    if (layer->CreateFeature(&f) != OGRERR_NONE) fail(path, "cannot write structure '" + st.name + "'");
  }
  out.CommitTransaction();
  return true;
}

}  // namespace

void write_structure_layers(const std::string& gpkg_path, const std::vector<StructureInfo>& structures,
                            const std::string& crs_wkt, const std::vector<double>& retained,
                            const std::vector<double>& upstream) {
  if (structures.empty()) return;
  register_drivers();
  CPLErrorReset();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  struct Pop {
    ~Pop() { CPLPopErrorHandler(); }
  } pop;
  DatasetPtr out(GDALDataset::Open(gpkg_path.c_str(), GDAL_OF_VECTOR | GDAL_OF_UPDATE));
  if (!out) fail(gpkg_path, "cannot open the GeoPackage to add the structures");
  for (const bool areas : {false, true}) {
    const std::string name = areas ? "structure_areas" : "check_dams";
    if (add_structure_layer(*out, name, areas, structures, crs_wkt, retained, upstream, gpkg_path))
      add_style(*out, name, structure_layer_qml(areas), name + " as built, labelled by name", gpkg_path);
  }
}

void write_class_polygons(const std::string& path, const std::vector<ClassLayer>& layers) {
  register_drivers();
  CPLErrorReset();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  struct Pop {
    ~Pop() { CPLPopErrorHandler(); }
  } pop;
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
  const std::string tmp = path + ".tmp.gpkg";
  std::error_code ec;
  fs::remove(tmp, ec);
  {
    GDALDriver* gpkg = GetGDALDriverManager()->GetDriverByName("GPKG");
    if (!gpkg) fail(path, "GDAL has no GPKG driver");
    DatasetPtr out(gpkg->Create(tmp.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    if (!out) fail(path, "cannot create the GeoPackage");
    try {
      for (const auto& l : layers) add_layer(*out, l, path);
      add_layer_styles(*out, layers, path);
    } catch (...) {
      out.reset();
      fs::remove(tmp, ec);
      throw;
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) throw std::runtime_error("write_class_polygons: cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
}

}  // namespace runout::terrain
