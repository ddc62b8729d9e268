// Arithmetic between grids on the same cell lattice: the difference rasters of a sweep against its baseline.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "runout/terrain/raster.hpp"

namespace runout::terrain {
namespace {

// Whole number of cells from `from` to `to` along an axis of cell size d; throws if it is not whole.
long cells_between(double from, double to, double d) {
  const double n = (to - from) / d;
  const double r = std::round(n);
  if (std::abs(n - r) > 1e-6) throw std::invalid_argument("difference_grid: the grids' cells are not aligned");
  return static_cast<long>(r);
}

}  // namespace

Grid difference_grid(const Grid& a, const Grid& b) {
  if (std::abs(a.dx - b.dx) > 1e-9 * a.dx || std::abs(a.dy - b.dy) > 1e-9 * a.dy)
    throw std::invalid_argument("difference_grid: the grids' cell sizes differ");
  const double x0 = std::min(a.x0, b.x0), y0 = std::max(a.y0, b.y0);
  const double x1 = std::max(a.x1(), b.x1()), y1 = std::min(a.y1(), b.y1());
  const int nx = static_cast<int>(cells_between(x0, x1, a.dx)), ny = static_cast<int>(cells_between(y1, y0, a.dy));
  // Nodata until either grid has a value there: a cell dry in both layouts is no difference of 0 to paint.
  Grid out(nx, ny, x0, y0, a.dx, a.dy, a.crs_wkt.empty() ? b.crs_wkt : a.crs_wkt, Grid::nodata);
  auto add = [&](const Grid& g, float sign) {
    const long di = cells_between(x0, g.x0, g.dx), dj = cells_between(g.y0, y0, g.dy);
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        const float v = g.at(i, j);
        if (std::isnan(v)) continue;
        float& o = out.at(static_cast<int>(i + di), static_cast<int>(j + dj));
        o = (std::isnan(o) ? 0.0f : o) + sign * v;
      }
  };
  add(a, 1.0f);
  add(b, -1.0f);
  return out;
}

}  // namespace runout::terrain
