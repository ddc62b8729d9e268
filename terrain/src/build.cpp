// Building a terrain scene: corridor, bed at dp with structures, boundary particles, release particles. The
// steps are in corridor.cpp, structures.cpp and particles.cpp (build_steps.hpp); this file checks the inputs
// and runs them in order.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "build_steps.hpp"

namespace runout::terrain {
namespace detail {

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}
std::string point(double x, double y) { return "(" + num(x) + ", " + num(y) + ")"; }
std::string structure_field(size_t k) { return "structures[" + std::to_string(k) + "]"; }

}  // namespace detail
namespace {

using detail::kNaN;
using detail::num;
using detail::point;

void require_inside_dem(const Grid& dem, const Polyline& line, const std::string& field, const std::string& what) {
  for (const auto& p : line) {
    if (p[0] < dem.x0 || p[0] > dem.x1() || p[1] < dem.y1() || p[1] > dem.y0)
      throw TerrainError(field, what + ": vertex " + point(p[0], p[1]) + " lies outside the DEM (x in [" +
                                    num(dem.x0) + ", " + num(dem.x1()) + "], y in [" + num(dem.y1()) + ", " +
                                    num(dem.y0) + "] in " + crs_name(dem.crs_wkt) + ")");
  }
}

// The release, structures and zones against the DEM, before any work. Returns the release's area.
double check_inputs(const TerrainSpec& spec, const Grid& dem) {
  if (spec.release.polygon.size() < 3) throw TerrainError("release.polygon", "needs at least 3 vertices");
  require_inside_dem(dem, spec.release.polygon, "release.polygon", "the release");
  const double release_area = polygon_area(spec.release.polygon);
  if (!(release_area > 0)) throw TerrainError("release.polygon", "has zero area");
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    const std::string field = detail::structure_field(k);
    if (!s.type) throw TerrainError(field, "'" + s.name + "' has no structure type");
    const size_t need = s.type->area ? 3 : 2;
    if (s.line.size() < need)
      throw TerrainError(field, "'" + s.name + "' needs at least " + std::to_string(need) + " vertices");
    require_inside_dem(dem, s.line, field, "'" + s.name + "'");
    if (s.type->area && !(polygon_area(s.line) > 0))
      throw TerrainError(field, "'" + s.name + "' has zero area");
  }
  for (size_t k = 0; k < spec.protected_zones.size(); ++k)
    if (spec.protected_zones[k].polygon.size() < 3)
      throw TerrainError("protected_zones[" + std::to_string(k) + "].polygon", "needs at least 3 vertices");
  return release_area;
}

}  // namespace

double TerrainModel::bed_at(double x, double y) const {
  const double mx = x + origin_x, my = y + origin_y;
  const double z = bed.sample(mx, my);
  if (!std::isnan(z)) return z;
  int i, j;  // at the corridor's edge the bilinear stencil leaves it: use the column itself
  if (!bed.cell_of(mx, my, i, j)) return kNaN;
  return bed.at(i, j);
}

bool TerrainModel::off_corridor(const Vec<3>& p) const {
  int i, j;
  if (bed.cell_of(p[0] + origin_x, p[1] + origin_y, i, j)) return std::isnan(bed_at(p[0], p[1]));
  // Past the corridor's box: off the corridor unless it went through a face on the DEM's edge (the engine
  // removes those as outflow from the DEM).
  const double lo[2] = {bed.x0 - origin_x, bed.y1() - origin_y}, hi[2] = {bed.x1() - origin_x, bed.y0 - origin_y};
  for (int d = 0; d < 2; ++d) {
    if (p[d] < lo[d] && open_faces[d][0]) return false;
    if (p[d] >= hi[d] && open_faces[d][1]) return false;
  }
  return true;
}

// Past the first layer of wall particles. The bed and the walls are columns at dp, each column's first-layer
// centre dp/2 under the top its particles reach. Under the bed: more than dp under the lowest column top of
// the cells bilinear interpolation weighs (the interpolated surface runs through the open corner at a step's
// foot, where a particle may rest). Inside a wall: in a column whose four neighbours are wall (past the face
// columns), with every column the stencil weighs wall (a staircase's inner corner touches an interior
// column's corner point), and more than dp under the lowest top the wall particles there reach (a wall's
// nominal top steps with the ground, and its particles stop up to dp/2 off it). Each rule once took a resting
// particle for a leak: docs/design.md, "The leaks at steps were the leak check's".
std::string TerrainModel::misplaced(const Vec<3>& p) const {
  const double mx = p[0] + origin_x, my = p[1] + origin_y;
  int i, j;
  if (!bed.cell_of(mx, my, i, j)) return {};  // outside the grid: the engine's domain faces decide
  const double b = bed_at(p[0], p[1]);
  std::ostringstream s;
  s.precision(8);
  if (std::isnan(b)) {
    s << "left the modelled corridor at map " << point(mx, my) << " (widen terrain.corridor)";
    return s.str();
  }
  Grid::Stencil around;
  bed.stencil(mx, my, around);
  double lowest_bed = b, lowest_top = std::numeric_limits<double>::infinity();
  bool walled_around = around.count > 0;  // every column the stencil weighs (1-4) is wall
  for (int k = 0; k < around.count; ++k) {
    const float z = bed.at(around.i[k], around.j[k]);
    if (!std::isnan(z)) lowest_bed = std::min(lowest_bed, static_cast<double>(z));
    // The wall as its particles stand (whole layers from the bed), not its nominal top.
    const size_t ck = static_cast<size_t>(around.j[k]) * bed.nx + around.i[k];
    if (const int n = detail::wall_count(*this, ck); n > 0)
      lowest_top = std::min(lowest_top, static_cast<double>(bed.values[ck]) + n * dp);
    else
      walled_around = false;
  }
  if (p[2] < lowest_bed - dp) {
    s << "is below the terrain at map " << point(mx, my) << ": z = " << p[2] << " m, ground " << b << " m";
    return s.str();
  }
  const size_t c = static_cast<size_t>(j) * bed.nx + i;
  if (!wall_interior.empty() && wall_interior[c] && walled_around && p[2] < lowest_top - dp) {
    s << "is inside the wall of '" << structures[wall_owner[c]].name << "' at map " << point(mx, my)
      << ", z = " << p[2] << " m";
    return s.str();
  }
  return {};
}

namespace {

// A hydrograph release's strip: the rectangle of `inflow_length` on the line's uphill side (the DEM decides
// which side that is), and the downhill normal.
Polyline inflow_strip(const ReleaseSpec& release, const Grid& dem, std::array<double, 2>& normal) {
  const Polyline& line = release.inflow_line;
  if (line.size() != 2) throw TerrainError("release.hydrograph.line", "must be a straight line of two points");
  require_inside_dem(dem, line, "release.hydrograph.line", "the inflow line");
  const double dx = line[1][0] - line[0][0], dy = line[1][1] - line[0][1], len = std::hypot(dx, dy);
  if (!(len > 0)) throw TerrainError("release.hydrograph.line", "has zero length");
  const double L = release.inflow_length, nx = -dy / len, ny = dx / len;
  const double mx = 0.5 * (line[0][0] + line[1][0]), my = 0.5 * (line[0][1] + line[1][1]);
  const double ahead = dem.sample(mx + L * nx, my + L * ny), behind = dem.sample(mx - L * nx, my - L * ny);
  if (std::isnan(ahead) || std::isnan(behind) || std::abs(ahead - behind) < 1e-3 * L)
    throw TerrainError("release.hydrograph.line", "the ground on either side of its midpoint within " + num(L) +
                                                      " m is missing or level: the downhill side is undefined");
  const double sign = ahead < behind ? 1.0 : -1.0;
  normal = {sign * nx, sign * ny};
  Polyline strip = line;
  strip.push_back({line[1][0] - L * normal[0], line[1][1] - L * normal[1]});
  strip.push_back({line[0][0] - L * normal[0], line[0][1] - L * normal[1]});
  return strip;
}

}  // namespace

TerrainModel build_terrain(const TerrainSpec& given, double dp, long max_particles) {
  if (!(dp > 0)) throw TerrainError("dp", "must be > 0");
  TerrainModel m;
  m.dp = dp;
  m.dem = load_dem_shared(given.dem_path, given.dem);
  TerrainSpec spec = given;
  const bool inflow = !spec.release.inflow_line.empty();
  if (inflow) spec.release.polygon = inflow_strip(spec.release, *m.dem, m.inflow_normal);
  const double release_area = check_inputs(spec, *m.dem);
  const std::vector<detail::Footprint> feet = detail::footprints(spec, *m.dem, dp);

  double release_depth = spec.release.depth;
  if (!(release_depth > 0)) release_depth = spec.release.volume / release_area;
  const detail::Corridor corridor = detail::corridor_cells(spec, m.dem, feet, release_depth, dp, m.max_energy_height);
  const detail::CorridorBox& box = corridor.box;
  m.corridor_area = box.kept * m.dem->cell_area();
  m.max_corridor_outflow = spec.corridor.max_outflow;
  m.modelled_fraction = static_cast<double>(box.kept) / static_cast<double>(box.valid);
  detail::lay_bed(m, *corridor.cells, box, spec.layers, max_particles);

  const std::vector<size_t> release_cols = detail::release_columns(spec.release.polygon, m.bed, dp);
  const std::vector<int> owner = detail::structure_owners(spec, feet, m.bed, dp);
  detail::regrade_and_excavate(m, spec, owner);
  detail::build_walls(m, spec, feet, owner);
  detail::storage_capacities(m, spec, feet, owner);

  detail::lay_boundary_particles(m, spec.layers, inflow ? 0 : release_cols.size(), release_depth, max_particles);
  if (inflow) {
    m.inflow_line = spec.release.inflow_line;
    m.release_depth = spec.release.depth;  // the inflow's; no particles are placed
  } else {
    detail::fill_release(m, spec.release, release_cols);
  }
  m.release_polygon = spec.release.polygon;
  m.protected_zones = spec.protected_zones;
  return m;
}

}  // namespace runout::terrain
