// Class grids to polygons (GDALPolygonize) in a GeoPackage: the inundated area and the intensity classes.
#include <cmath>
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
#include <ogrsf_frmts.h>

#include "runout/terrain/raster.hpp"

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

void add_layer(GDALDataset& out, const ClassLayer& spec, const std::string& path) {
  if (!spec.classes) throw std::invalid_argument("write_class_polygons: layer '" + spec.name + "' has no grid");
  const Grid& g = *spec.classes;
  OGRSpatialReference srs;
  if (!g.crs_wkt.empty()) srs.importFromWkt(g.crs_wkt.c_str());
  OGRLayer* layer = out.CreateLayer(spec.name.c_str(), g.crs_wkt.empty() ? nullptr : &srs, wkbPolygon, nullptr);
  if (!layer) fail(path, "cannot create layer '" + spec.name + "'");
  for (const auto& [name, type] : {std::pair<const char*, OGRFieldType>{"class", OFTInteger}, {"label", OFTString},
                                   {"area_m2", OFTReal}}) {
    OGRFieldDefn f(name, type);
    if (layer->CreateField(&f) != OGRERR_NONE) fail(path, std::string("cannot add field ") + name);
  }
  DatasetPtr raster = class_raster(g, path);
  GDALRasterBandH band = GDALRasterBand::ToHandle(raster->GetRasterBand(1));
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

}  // namespace

void write_class_polygons(const std::string& path, const std::vector<ClassLayer>& layers) {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
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
