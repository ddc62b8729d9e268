// The bed's wall particles as a wall source: the solver lays the tiles near the flow (engine wall_source.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "runout/terrain/terrain.hpp"

namespace runout::terrain {
namespace {

// Column (ix, iy) of the tile grid is bed column i = ix, row j = ny - 1 - iy (rows run north to south, the
// grid south to north, as the local y axis); its layers are cut into slabs of kBedSlabLayers from the top.
// A particle's id is its place in the column-by-column, top-down order, the order of the bed laid whole.
class BedWallSource final : public WallSource<3> {
 public:
  // The count and the lowest corner are all a scene's build and an estimate ask for: one pass over the columns.
  // The per-column index (three arrays the size of the bed grid, a quarter of a catchment's estimate) is made
  // when a run first asks for tiles.
  explicit BedWallSource(std::shared_ptr<const TerrainModel> model) : m_(std::move(model)) {
    const Grid& bed = m_->bed;
    lowest_ = Vec<3>::Constant(std::numeric_limits<real>::infinity());
    for (int j = 0; j < bed.ny; ++j)
      for (int i = 0; i < bed.nx; ++i) {
        const size_t c = static_cast<size_t>(j) * bed.nx + i;
        const int layers = m_->bed_layers[c];
        total_ += layers;
        if (layers > 0) lowest_ = lowest_.cwiseMin(position(i, j, c, layers - 1));  // a minimum: any order
      }
  }

  WallTileGrid tiles() const override { return index().grid; }
  uint64_t first_index(int64_t t) const override {
    const Slab sl = slab_of(t);
    return index().first[sl.column] + static_cast<uint64_t>(sl.first_layer);
  }
  uint64_t total() const override { return total_; }
  Vec<3> lowest() const override { return lowest_; }

  void lay(int64_t t, std::vector<Vec<3>>& positions, std::vector<Vec<3>>& normals,
           std::vector<uint32_t>& tags) const override {
    const Slab sl = slab_of(t);
    const int nx = m_->bed.nx;  // the tile grid's columns are the bed's
    const int i = static_cast<int>(sl.column % nx), j = m_->bed.ny - 1 - static_cast<int>(sl.column / nx);
    const size_t c = static_cast<size_t>(j) * m_->bed.nx + i;
    const Vec<3> n = bed_normal(i, j);
    const int end = std::min<int>(m_->bed_layers[c], sl.first_layer + kBedSlabLayers);
    for (int q = sl.first_layer; q < end; ++q) {
      positions.push_back(position(i, j, c, q));
      normals.push_back(n);
      tags.push_back(1);
    }
  }

 private:
  std::shared_ptr<const TerrainModel> m_;
  uint64_t total_ = 0;
  Vec<3> lowest_;
  struct Index {
    WallTileGrid grid;
    std::vector<uint64_t> first;  // per grid column: the particles of the columns before it
  };
  mutable std::once_flag once_;
  mutable Index index_;

  const Index& index() const {
    std::call_once(once_, [this] { make_index(index_); });
    return index_;
  }
  void make_index(Index& x) const {
    const Grid& bed = m_->bed;
    WallTileGrid& grid = x.grid;
    grid.size = m_->dp;
    grid.x0 = bed.x0 - m_->origin_x;
    grid.y0 = bed.y1() - m_->origin_y;
    grid.nx = bed.nx;
    grid.ny = bed.ny;
    grid.spread = 0;  // a column's particles are on its axis
    grid.slab = kBedSlabLayers * m_->dp;
    grid.slab_extent = (kBedSlabLayers - 1) * m_->dp;
    const int64_t columns = grid.columns();
    grid.column_first.assign(static_cast<size_t>(columns) + 1, 0);
    grid.column_top.assign(static_cast<size_t>(columns), 0.0);
    x.first.assign(static_cast<size_t>(columns) + 1, 0);
    for (int64_t k = 0; k < columns; ++k) {
      const int i = static_cast<int>(k % grid.nx), j = bed.ny - 1 - static_cast<int>(k / grid.nx);
      const size_t c = static_cast<size_t>(j) * bed.nx + i;
      const int layers = m_->bed_layers[c];
      x.first[k + 1] = x.first[k] + layers;
      grid.column_first[k + 1] = grid.column_first[k] + (layers + kBedSlabLayers - 1) / kBedSlabLayers;
      if (layers == 0) continue;
      grid.column_top[k] = position(i, j, c, 0)[2];
    }
  }

  struct Slab {
    int64_t column;
    int first_layer;
  };
  Slab slab_of(int64_t t) const {
    const auto& cf = index().grid.column_first;
    const int64_t k = std::upper_bound(cf.begin(), cf.end(), t) - cf.begin() - 1;
    return {k, static_cast<int>(t - cf[static_cast<size_t>(k)]) * kBedSlabLayers};
  }

  // As the bed was laid before tiles (the same expressions, so the same doubles).
  Vec<3> position(int i, int j, size_t c, int q) const {
    const Grid& bed = m_->bed;
    const double b = bed.values[c];
    return Vec<3>(bed.cx(i) - m_->origin_x, bed.cy(j) - m_->origin_y, b - (q + 0.5) * m_->dp);
  }

  // The bed's upward unit normal at column (i, j): central differences of the bed grid (one-sided at its edge).
  Vec<3> bed_normal(int i, int j) const {
    const Grid& bed = m_->bed;
    auto at = [&](int ii, int jj) { return bed.values[static_cast<size_t>(jj) * bed.nx + ii]; };
    // A neighbour off the grid or off the corridor (NaN) is replaced by the column itself.
    auto on_bed = [&](int ii, int jj, int fallback_i, int fallback_j, bool along_x) {
      const bool inside = along_x ? (ii >= 0 && ii < bed.nx) : (jj >= 0 && jj < bed.ny);
      return inside && std::isfinite(at(ii, jj)) ? (along_x ? ii : jj) : (along_x ? fallback_i : fallback_j);
    };
    const int i0 = on_bed(i - 1, j, i, j, true), i1 = on_bed(i + 1, j, i, j, true);
    const int j0 = on_bed(i, j - 1, i, j, false), j1 = on_bed(i, j + 1, i, j, false);
    const double dbdx = i1 > i0 ? (at(i1, j) - at(i0, j)) / (bed.cx(i1) - bed.cx(i0)) : 0.0;
    const double dbdy = j1 > j0 ? (at(i, j1) - at(i, j0)) / (bed.cy(j1) - bed.cy(j0)) : 0.0;
    return Vec<3>(-dbdx, -dbdy, 1.0).normalized();
  }
};

}  // namespace

std::shared_ptr<const WallSource<3>> bed_wall_source(std::shared_ptr<const TerrainModel> model) {
  return std::make_shared<BedWallSource>(std::move(model));
}

}  // namespace runout::terrain
