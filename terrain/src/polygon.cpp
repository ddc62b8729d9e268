// Plane geometry on map coordinates: polygon area and containment, distance to a polyline.
#include <algorithm>
#include <cmath>
#include <limits>

#include "runout/engine/geometry.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout::terrain {

double polygon_area(const Polyline& p) {
  double a = 0.0;
  for (size_t k = 0, n = p.size(); k < n; ++k) {
    const auto& u = p[k];
    const auto& v = p[(k + 1) % n];
    a += u[0] * v[1] - v[0] * u[1];
  }
  return 0.5 * std::abs(a);
}

bool inside_polygon(const Polyline& p, double x, double y) {
  // Even-odd crossing rule; points exactly on an edge may go either way, which is fine on a lattice.
  bool in = false;
  for (size_t k = 0, n = p.size(), m = n - 1; k < n; m = k++) {
    const double xi = p[k][0], yi = p[k][1], xj = p[m][0], yj = p[m][1];
    if ((yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) in = !in;
  }
  return in;
}

double distance_to_polyline(const Polyline& line, double x, double y, double* along) {
  const NearestSegment n = nearest_segment(line, x, y);
  double best = n.distance, best_s = 0.0;
  if (line.size() == 1) best = std::hypot(x - line[0][0], y - line[0][1]);
  if (along && n.index >= 0) {
    for (int k = 0; k <= n.index; ++k) {  // the arc length summed in the order it always was
      const double ex = line[k + 1][0] - line[k][0], ey = line[k + 1][1] - line[k][1];
      const double len = std::sqrt(ex * ex + ey * ey);
      best_s = k < n.index ? best_s + len : best_s + n.t * len;
    }
  }
  if (along) *along = best_s;
  return best;
}

}  // namespace runout::terrain
