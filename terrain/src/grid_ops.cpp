// Arithmetic between grids on the same cell lattice: the difference rasters of a sweep against its baseline,
// the exceedance probabilities of an ensemble.
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
  if (std::abs(n - r) > 1e-6) throw std::invalid_argument("the grids' cells are not aligned");
  return static_cast<long>(r);
}

// A nodata grid covering every grid given (all on one lattice: same cell size, edges whole cells apart).
Grid union_grid(const std::vector<const Grid*>& grids, const char* what) {
  const Grid& a = *grids.front();
  double x0 = a.x0, y0 = a.y0, x1 = a.x1(), y1 = a.y1();
  for (const Grid* g : grids) {
    if (std::abs(g->dx - a.dx) > 1e-9 * a.dx || std::abs(g->dy - a.dy) > 1e-9 * a.dy)
      throw std::invalid_argument(std::string(what) + ": the grids' cell sizes differ");
    x0 = std::min(x0, g->x0), y0 = std::max(y0, g->y0), x1 = std::max(x1, g->x1()), y1 = std::min(y1, g->y1());
  }
  std::string crs;
  for (const Grid* g : grids)
    if (crs.empty()) crs = g->crs_wkt;
  const int nx = static_cast<int>(cells_between(x0, x1, a.dx)), ny = static_cast<int>(cells_between(y1, y0, a.dy));
  return Grid(nx, ny, x0, y0, a.dx, a.dy, crs, Grid::nodata);
}

// Calls f(cell of `out`, value) for every cell of g with a value; g lies on out's lattice inside it.
template <class F>
void each_value(const Grid& g, Grid& out, F&& f) {
  const long di = cells_between(out.x0, g.x0, g.dx), dj = cells_between(g.y0, out.y0, g.dy);
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const float v = g.at(i, j);
      if (!std::isnan(v)) f(out.at(static_cast<int>(i + di), static_cast<int>(j + dj)), v);
    }
}

}  // namespace

Grid difference_grid(const Grid& a, const Grid& b) {
  // Nodata until either grid has a value there: a cell dry in both layouts is no difference of 0 to paint.
  Grid out = union_grid({&a, &b}, "difference_grid");
  each_value(a, out, [](float& o, float v) { o = (std::isnan(o) ? 0.0f : o) + v; });
  each_value(b, out, [](float& o, float v) { o = (std::isnan(o) ? 0.0f : o) - v; });
  return out;
}

Grid exceedance_grid(const std::vector<const Grid*>& members, double threshold) {
  if (members.empty()) throw std::invalid_argument("exceedance_grid: no members");
  Grid out = union_grid(members, "exceedance_grid");
  Grid counts = out.like(0.0f);
  for (const Grid* g : members)
    each_value(*g, counts, [threshold](float& c, float v) { c += v >= threshold ? 1.0f : 0.0f; });
  const float n = static_cast<float>(members.size());
  for (size_t k = 0; k < out.values.size(); ++k)
    out.values[k] = counts.values[k] > 0.0f ? counts.values[k] / n : Grid::nodata;
  return out;
}

}  // namespace runout::terrain
