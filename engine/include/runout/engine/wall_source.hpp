#pragma once
// Wall particles made on demand. A wall source (a terrain's bed) cuts its wall particles into tiles of a
// regular horizontal grid, optionally cut in depth too, and lays the particles of any tile when asked, always
// the same ones in the same order. The solver keeps alive only the tiles within kernel reach of the flow (plus
// a margin), so a run's memory and work follow the wetted footprint, not the source's area (docs/design.md,
// "Walls near the flow").
#include <array>
#include <cstdint>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {

// Column (ix, iy) holds the particles with x in [x0 + ix size, x0 + (ix + 1) size) and y in [y0 + iy size, ...)
// (2D: the x axis only, ny = 1), numbered k = iy nx + ix; `spread` says how far they lie from its centre along
// x and y (size / 2 when anywhere in it, 0 when all on its axis). Without slabs each column is one tile, t = k.
// With them (3D, slab > 0) a column is cut in depth: its tiles are column_first[k] .. column_first[k + 1] - 1,
// top down, tile column_first[k] + s holding the particles with z in [top - s slab - slab_extent, top - s slab]
// (top = column_top[k]), so a thin flow wakes only the layers within its reach (docs/design.md).
struct WallTileGrid {
  real x0 = 0, y0 = 0, size = 1;
  int64_t nx = 0, ny = 1;
  real spread = 0.5;  // [size]
  real slab = 0, slab_extent = 0;
  std::vector<int64_t> column_first;  // nx ny + 1 entries when slab > 0
  std::vector<real> column_top;       // nx ny entries when slab > 0
  int64_t columns() const { return nx * ny; }
  int64_t count() const { return slab > 0 ? column_first.back() : columns(); }
};

template <int D>
class WallSource {
 public:
  virtual ~WallSource() = default;
  virtual WallTileGrid tiles() const = 0;
  // Appends tile t's particles: positions, the wall's unit normal at each (the axis the extrapolated wall
  // pressure's hydrostatic term acts along; its sign does not matter) and boundary tags. The same particles
  // in the same order every call.
  virtual void lay(int64_t t, std::vector<Vec<D>>& positions, std::vector<Vec<D>>& normals,
                   std::vector<uint32_t>& tags) const = 0;
  // Particles in the tiles before t (in tile order): a particle's id is that plus its place in its tile, so
  // ids are the same whether a tile is laid at the start or during the run.
  virtual uint64_t first_index(int64_t t) const = 0;
  // Every particle the source can lay.
  virtual uint64_t total() const = 0;
  // The lowest corner over all of them (the solver's cell origin does not move as tiles come and go).
  virtual Vec<D> lowest() const = 0;
};

}  // namespace runout
