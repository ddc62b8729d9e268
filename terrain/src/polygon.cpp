// Plane geometry on map coordinates: polygon area and containment, distance to a polyline.
#include <algorithm>
#include <cmath>
#include <limits>

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
  double best = std::numeric_limits<double>::infinity(), best_s = 0.0, s0 = 0.0;
  for (size_t k = 0; k + 1 < line.size(); ++k) {
    const double ax = line[k][0], ay = line[k][1];
    const double ex = line[k + 1][0] - ax, ey = line[k + 1][1] - ay;
    const double len2 = ex * ex + ey * ey, len = std::sqrt(len2);
    const double t = len2 > 0 ? std::clamp(((x - ax) * ex + (y - ay) * ey) / len2, 0.0, 1.0) : 0.0;
    const double d = std::hypot(x - (ax + t * ex), y - (ay + t * ey));
    if (d < best) {
      best = d;
      best_s = s0 + t * len;
    }
    s0 += len;
  }
  if (line.size() == 1) best = std::hypot(x - line[0][0], y - line[0][1]);
  if (along) *along = best_s;
  return best;
}

const char* kind_name(StructureKind kind) {
  switch (kind) {
    case StructureKind::check_dam: return "check_dam";
    case StructureKind::deposition_area: return "deposition_area";
    case StructureKind::retention_basin: return "retention_basin";
  }
  return "?";
}

}  // namespace runout::terrain
