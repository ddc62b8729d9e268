// Vector inputs through OGR: a layer's features as a scene's line or polygon, reprojected to the working CRS
// (vector.hpp). Rings are joined into one path here (join_rings) and split back for drawing (split_rings).
#include "runout/terrain/vector.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <cpl_error.h>
#include <gdal.h>
#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include "shape_cache.hpp"

namespace runout::terrain {
namespace {

double signed_area(const Polyline& r) {
  double a = 0.0;
  for (size_t k = 0, n = r.size(); k < n; ++k) a += r[k][0] * r[(k + 1) % n][1] - r[(k + 1) % n][0] * r[k][1];
  return 0.5 * a;
}

struct QuietGdal {
  QuietGdal() {
    static std::once_flag once;
    std::call_once(once, [] { GDALAllRegister(); });
    CPLErrorReset();
    CPLPushErrorHandler(CPLQuietErrorHandler);
  }
  ~QuietGdal() { CPLPopErrorHandler(); }
  QuietGdal(const QuietGdal&) = delete;
  QuietGdal& operator=(const QuietGdal&) = delete;
};

std::string gdal_message() {
  const char* msg = CPLGetLastErrorMsg();
  return (msg && *msg) ? std::string(msg) : std::string("no details from GDAL");
}

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(GDALDataset::ToHandle(d)); }
};
using VectorDataset = std::unique_ptr<GDALDataset, DatasetCloser>;
using Geometry = std::unique_ptr<OGRGeometry>;

// What a reader of one field needs to say what went wrong.
struct Context {
  const LayerRef& ref;
  const std::string& field;
  [[noreturn]] void fail(const std::string& what) const {
    throw TerrainError(field, "layer '" + ref.path + (ref.name.empty() ? "" : "', '" + ref.name) + "': " + what);
  }
};

VectorDataset open_vector(const Context& c) {
  VectorDataset ds(GDALDataset::FromHandle(GDALOpenEx(
      c.ref.path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, nullptr, nullptr)));
  if (!ds) throw TerrainError(c.field, "cannot open '" + c.ref.path + "' as a vector file: " + gdal_message());
  return ds;
}

std::string layer_names(GDALDataset& ds) {
  std::string list;
  for (int k = 0; k < ds.GetLayerCount(); ++k) list += std::string(k ? ", " : "") + ds.GetLayer(k)->GetName();
  return list.empty() ? "none" : list;
}

OGRLayer& find_layer(GDALDataset& ds, const Context& c) {
  if (c.ref.name.empty()) {
    if (ds.GetLayerCount() != 1)
      c.fail("has " + std::to_string(ds.GetLayerCount()) + " layers (" + layer_names(ds) + "): name one with \"name\"");
    return *ds.GetLayer(0);
  }
  OGRLayer* layer = ds.GetLayerByName(c.ref.name.c_str());
  if (!layer) c.fail("no such layer (layers: " + layer_names(ds) + ")");
  return *layer;
}

// The transformation from the layer's CRS (or the one the scene gives) to the working CRS; null when they
// are the same.
std::unique_ptr<OGRCoordinateTransformation> to_working(OGRLayer& layer, const std::string& working_wkt,
                                                        const Context& c) {
  OGRSpatialReference src, dst;
  if (!c.ref.crs.empty()) {
    if (src.SetFromUserInput(c.ref.crs.c_str()) != OGRERR_NONE)
      c.fail("crs '" + c.ref.crs + "' is not a coordinate reference system GDAL/PROJ knows");
  } else if (const OGRSpatialReference* s = layer.GetSpatialRef(); s && !s->IsEmpty()) {
    src = *s;
  } else {
    c.fail("has no coordinate reference system; give one with \"crs\" (for instance EPSG:32616)");
  }
  if (dst.importFromWkt(working_wkt.c_str()) != OGRERR_NONE) c.fail("the working CRS is unreadable");
  src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  dst.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  if (src.IsSame(&dst)) return nullptr;
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&src, &dst));
  if (!ct) c.fail("cannot transform from " + std::string(src.GetName() ? src.GetName() : "its CRS") + " to " +
                  (dst.GetName() ? dst.GetName() : "the working CRS") + ": " + gdal_message());
  return ct;
}

// The features that pass the filter, their geometries in the working CRS.
std::vector<Geometry> read_geometries(OGRLayer& layer, OGRCoordinateTransformation* ct, const Context& c) {
  if (layer.SetAttributeFilter(c.ref.where.empty() ? nullptr : c.ref.where.c_str()) != OGRERR_NONE)
    c.fail("where \"" + c.ref.where + "\" is not a filter GDAL accepts: " + gdal_message());
  layer.ResetReading();
  CPLErrorReset();  // a driver that runs the filter as SQL (GeoPackage) refuses a bad one only when reading
  std::vector<Geometry> out;
  for (auto& feature : layer) {
    OGRGeometry* g = feature->GetGeometryRef();
    if (!g || g->IsEmpty()) c.fail("feature " + std::to_string(feature->GetFID()) + " has no geometry");
    Geometry geom(g->clone());
    if (ct && geom->transform(ct) != OGRERR_NONE)
      c.fail("cannot reproject feature " + std::to_string(feature->GetFID()) + ": " + gdal_message());
    out.push_back(std::move(geom));
  }
  if (CPLGetLastErrorType() == CE_Failure || CPLGetLastErrorType() == CE_Fatal)
    c.fail("reading with where \"" + c.ref.where + "\" failed (not a filter GDAL accepts?): " + gdal_message());
  layer.SetAttributeFilter(nullptr);
  if (out.empty()) c.fail(c.ref.where.empty() ? "has no features" : "where \"" + c.ref.where + "\" matches no feature");
  return out;
}

// A ring's vertices without the closing repeat.
Polyline ring_points(const OGRLinearRing& ring) {
  Polyline r;
  for (int k = 0; k < ring.getNumPoints(); ++k) r.push_back({ring.getX(k), ring.getY(k)});
  if (r.size() > 1 && r.front() == r.back()) r.pop_back();
  return r;
}

Polyline line_shape(const std::vector<Geometry>& gs, const Context& c) {
  if (gs.size() != 1) c.fail(std::to_string(gs.size()) + " features match; this field takes one line (use \"where\")");
  const OGRGeometry* g = gs.front().get();
  const auto type = wkbFlatten(g->getGeometryType());
  if (type == wkbMultiLineString && g->toMultiLineString()->getNumGeometries() == 1)
    g = g->toMultiLineString()->getGeometryRef(0);
  else if (type != wkbLineString)
    c.fail("the geometry is a " + std::string(OGRGeometryTypeToName(type)) + "; this field takes a LineString");
  const OGRLineString* l = g->toLineString();
  Polyline out;
  for (int k = 0; k < l->getNumPoints(); ++k) out.push_back({l->getX(k), l->getY(k)});
  return out;
}

VectorShape polygon_shape(const std::vector<Geometry>& gs, bool multi, const Context& c) {
  if (!multi && gs.size() != 1)
    c.fail(std::to_string(gs.size()) + " features match; this field takes one polygon (use \"where\")");
  OGRMultiPolygon all;
  for (const auto& g : gs) {
    const auto type = wkbFlatten(g->getGeometryType());
    if (type == wkbPolygon) {
      all.addGeometry(g.get());
    } else if (type == wkbMultiPolygon) {
      for (const auto* p : *g->toMultiPolygon()) all.addGeometry(p);
    } else {
      c.fail("a feature's geometry is a " + std::string(OGRGeometryTypeToName(type)) + "; this field takes " +
             (multi ? "Polygons or MultiPolygons" : "a Polygon"));
    }
  }
  if (!all.IsValid()) c.fail("the polygons are not valid (a ring crosses itself, or parts or holes overlap)");
  VectorShape s;
  s.parts = static_cast<size_t>(all.getNumGeometries());
  std::vector<Polyline> rings;
  std::vector<bool> hole;
  for (const auto* p : all) {
    rings.push_back(ring_points(*p->getExteriorRing()));
    hole.push_back(false);
    for (int k = 0; k < p->getNumInteriorRings(); ++k) {
      rings.push_back(ring_points(*p->getInteriorRing(k)));
      hole.push_back(true);
      ++s.holes;
    }
  }
  if (!multi && (s.parts != 1 || s.holes != 0))
    c.fail("has " + std::to_string(s.parts) + " parts and " + std::to_string(s.holes) +
           " holes; this field takes a single ring (one Polygon without holes)");
  for (const auto& r : rings)
    if (r.size() < 3) c.fail("a ring has fewer than 3 vertices");
  s.path = join_rings(rings, hole);
  return s;
}

}  // namespace

Polyline join_rings(const std::vector<Polyline>& rings, const std::vector<bool>& is_hole) {
  if (rings.size() == 1 && !is_hole.front()) return rings.front();  // a simple polygon as it was written
  Polyline out;
  for (size_t k = 0; k < rings.size(); ++k) {
    Polyline r = rings[k];
    const bool ccw = signed_area(r) > 0;
    if (ccw == is_hole[k]) std::reverse(r.begin() + 1, r.end());  // keeps r[0] first
    out.insert(out.end(), r.begin(), r.end());
    out.push_back(r.front());
    if (k > 0) out.push_back(out.front());  // back along the bridge to the first ring's first vertex
  }
  return out;
}

std::vector<Polyline> split_rings(const Polyline& path) {
  if (path.empty()) return {};
  const MapPoint a = path.front();
  size_t end = 1;
  while (end < path.size() && path[end] != a) ++end;
  if (end == path.size()) return {path};  // a simple polygon or a line
  std::vector<Polyline> rings{Polyline(path.begin(), path.begin() + static_cast<long>(end))};
  for (size_t pos = end + 1; pos < path.size();) {
    const MapPoint b = path[pos];
    size_t q = pos + 1;
    while (q < path.size() && path[q] != b) ++q;
    rings.emplace_back(path.begin() + static_cast<long>(pos), path.begin() + static_cast<long>(q));
    pos = q + 2;  // past the ring's closing vertex and the bridge back to a
  }
  return rings;
}

namespace {

VectorShape read_shape_from_file(const LayerRef& ref, ShapeKind kind, const std::string& working_crs_wkt,
                                  const std::string& field) {
  QuietGdal quiet;
  const Context c{ref, field};
  VectorDataset ds = open_vector(c);
  OGRLayer& layer = find_layer(*ds, c);
  const auto ct = to_working(layer, working_crs_wkt, c);
  const std::vector<Geometry> gs = read_geometries(layer, ct.get(), c);
  VectorShape s;
  if (kind == ShapeKind::line) {
    s.path = line_shape(gs, c);
    s.parts = 1;
    if (s.path.size() < 2) c.fail("the line has fewer than 2 vertices");
  } else {
    s = polygon_shape(gs, kind == ShapeKind::multipolygon, c);
  }
  s.features = gs.size();
  for (const auto& p : s.path)
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) c.fail("a vertex is not finite after reprojection");
  return s;
}

}  // namespace

VectorShape read_vector_shape(const LayerRef& ref, ShapeKind kind, const std::string& working_crs_wkt,
                              const std::string& field) {
  // A shape kept under these bytes and settings passed every check of read_shape_from_file when it was read.
  const std::string key = detail::shape_key(ref, kind, working_crs_wkt);
  if (!key.empty())
    if (std::optional<VectorShape> kept = detail::cached_shape(key)) return *kept;
  VectorShape s = read_shape_from_file(ref, kind, working_crs_wkt, field);
  if (!key.empty()) detail::keep_shape(key, s);
  return s;
}

}  // namespace runout::terrain
