// CRS lookups by user input (EPSG codes, WKT, PROJ strings), for scenes and tests that name a CRS.
#include <ogr_spatialref.h>

#include "runout/terrain/raster.hpp"

namespace runout::terrain {

std::string crs_wkt_from(const std::string& user_input) {
  OGRSpatialReference srs;
  if (user_input.empty() || srs.SetFromUserInput(user_input.c_str()) != OGRERR_NONE)
    throw TerrainError("terrain.crs", "'" + user_input + "' is not a coordinate reference system GDAL/PROJ knows "
                                      "(use for instance EPSG:32616)");
  char* wkt = nullptr;
  srs.exportToWkt(&wkt);
  std::string out = wkt ? wkt : "";
  CPLFree(wkt);
  return out;
}

}  // namespace runout::terrain
