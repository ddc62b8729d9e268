// The bed's wall particles as a wall source: the solver lays the tiles near the flow (engine wall_source.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "runout/terrain/terrain.hpp"

namespace runout::terrain {
namespace {

// Tile (ix, iy) holds bed columns i with i / k == ix and rows j with (ny - 1 - j) / k == iy (rows run north to
// south, tiles south to north, as the local y axis). A column's particle sits half a column inside its tile,
// so rounding never puts it in the next one.
class BedWallSource final : public WallSource<3> {
 public:
  explicit BedWallSource(std::shared_ptr<const TerrainModel> model) : m_(std::move(model)) {
    const Grid& bed = m_->bed;
    grid_.size = kBedTileColumns * m_->dp;
    grid_.x0 = bed.x0 - m_->origin_x;
    grid_.y0 = bed.y1() - m_->origin_y;
    grid_.nx = (bed.nx + kBedTileColumns - 1) / kBedTileColumns;
    grid_.ny = (bed.ny + kBedTileColumns - 1) / kBedTileColumns;
    first_.assign(static_cast<size_t>(grid_.count()) + 1, 0);
    lowest_ = Vec<3>::Constant(std::numeric_limits<real>::infinity());
    for (int64_t t = 0; t < grid_.count(); ++t) {
      uint64_t n = 0;
      for_columns(t, [&](int i, int j, size_t c) {
        n += m_->bed_layers[c];
        if (m_->bed_layers[c] == 0) return;
        const Vec<3> deepest = position(i, j, c, m_->bed_layers[c] - 1);
        lowest_ = lowest_.cwiseMin(deepest);
      });
      first_[t + 1] = first_[t] + n;
    }
  }

  WallTileGrid tiles() const override { return grid_; }
  uint64_t first_index(int64_t t) const override { return first_[t]; }
  uint64_t total() const override { return first_.back(); }
  Vec<3> lowest() const override { return lowest_; }

  void lay(int64_t t, std::vector<Vec<3>>& positions, std::vector<Vec<3>>& normals,
           std::vector<uint32_t>& tags) const override {
    for_columns(t, [&](int i, int j, size_t c) {
      const Vec<3> n = bed_normal(i, j);
      for (int q = 0; q < m_->bed_layers[c]; ++q) {
        positions.push_back(position(i, j, c, q));
        normals.push_back(n);
        tags.push_back(1);
      }
    });
  }

 private:
  std::shared_ptr<const TerrainModel> m_;
  WallTileGrid grid_;
  std::vector<uint64_t> first_;
  Vec<3> lowest_;

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

  template <class F>
  void for_columns(int64_t t, F&& f) const {
    const Grid& bed = m_->bed;
    const int ix = static_cast<int>(t % grid_.nx), iy = static_cast<int>(t / grid_.nx);
    const int i0 = ix * kBedTileColumns, i1 = std::min(bed.nx, i0 + kBedTileColumns);
    const int j1 = bed.ny - 1 - iy * kBedTileColumns, j0 = std::max(0, j1 - kBedTileColumns + 1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i < i1; ++i) f(i, j, static_cast<size_t>(j) * bed.nx + i);
  }
};

}  // namespace

std::shared_ptr<const WallSource<3>> bed_wall_source(std::shared_ptr<const TerrainModel> model) {
  return std::make_shared<BedWallSource>(std::move(model));
}

}  // namespace runout::terrain
