#pragma once
// The grids load_dem made, kept by what they were made from (raster.cpp's content key: the SHA-256 of every
// file GDAL reads for the DEM, and the options), so a service that estimates or validates many jobs on one
// DEM warps it once. Bounded by bytes, the least recently used grid out first; thread-safe.
#include <memory>
#include <string>

#include "runout/terrain/raster.hpp"

namespace runout::terrain::detail {

// At most this many bytes of grid values are kept: a 10 km by 10 km catchment at 2 m is 100 MB, and the
// service holds a few DEMs at once.
constexpr size_t kDemCacheBytes = size_t{256} << 20;

std::shared_ptr<const Grid> cached_dem(const std::string& key);
// Keeps `grid` under `key` (a grid larger than the bound is not kept).
void keep_dem(const std::string& key, std::shared_ptr<const Grid> grid);

}  // namespace runout::terrain::detail
