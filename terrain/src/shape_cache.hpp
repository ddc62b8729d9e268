#pragma once
// The shapes read_vector_shape made, kept by what they were made from: the SHA-256 of the layer's file and of
// its sidecars (a shapefile's .shx, .dbf, .prj; a GeoPackage's -wal), the layer, the filter, the CRSs and the
// kind asked for. A service that checks, prices and maps many jobs on one layer file then opens it once: a
// GeoPackage's SQLite open and query was a fifth of a catchment estimate. At most kShapeCacheEntries, the least
// recently used out first; thread-safe.
#include <optional>
#include <string>

#include "runout/terrain/vector.hpp"

namespace runout::terrain::detail {

constexpr size_t kShapeCacheEntries = 512;

// "" when the shape is not kept: a file that cannot be read, a GDAL virtual path (/vsi...), or an OGR VRT
// (whose sources are other files).
std::string shape_key(const LayerRef& ref, ShapeKind kind, const std::string& working_crs_wkt);
std::optional<VectorShape> cached_shape(const std::string& key);
void keep_shape(const std::string& key, const VectorShape& shape);

}  // namespace runout::terrain::detail
