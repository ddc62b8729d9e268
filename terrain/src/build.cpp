// Building a terrain scene: corridor, bed at dp with structures, boundary particles, release particles.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <queue>
#include <sstream>

#include "runout/terrain/terrain.hpp"

namespace runout::terrain {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}
std::string point(double x, double y) { return "(" + num(x) + ", " + num(y) + ")"; }

std::string structure_field(size_t k, const std::string& name) {
  return "structures[" + std::to_string(k) + "]";
}

void require_inside_dem(const Grid& dem, const Polyline& line, const std::string& field, const std::string& what) {
  for (const auto& p : line) {
    if (p[0] < dem.x0 || p[0] > dem.x1() || p[1] < dem.y1() || p[1] > dem.y0)
      throw TerrainError(field, what + ": vertex " + point(p[0], p[1]) + " lies outside the DEM (x in [" +
                                    num(dem.x0) + ", " + num(dem.x1()) + "], y in [" + num(dem.y1()) + ", " +
                                    num(dem.y0) + "] in " + crs_name(dem.crs_wkt) + ")");
  }
}

// Energy-line reach: the highest "energy head" any path from the release can carry to a cell, where the
// head starts at the release surface and falls by tan(travel angle) per metre travelled. A cell is reached
// when its head is at or above the ground. Dijkstra on a max-heap of heads (heads only decrease).
std::vector<char> energy_line_reach(const Grid& dem, const std::vector<std::pair<size_t, double>>& sources,
                                    double tan_angle, double& max_energy_height) {
  const size_t n = dem.values.size();
  std::vector<double> head(n, -std::numeric_limits<double>::infinity());
  using Item = std::pair<double, size_t>;
  std::priority_queue<Item> queue;
  for (const auto& [c, h] : sources) {
    if (h > head[c]) {
      head[c] = h;
      queue.push({h, c});
    }
  }
  const double diag = std::hypot(dem.dx, dem.dy);
  const int di[8] = {1, -1, 0, 0, 1, 1, -1, -1}, dj[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const double dist[8] = {dem.dx, dem.dx, dem.dy, dem.dy, diag, diag, diag, diag};
  while (!queue.empty()) {
    const auto [h, c] = queue.top();
    queue.pop();
    if (h < head[c]) continue;
    const int i = static_cast<int>(c % dem.nx), j = static_cast<int>(c / dem.nx);
    for (int k = 0; k < 8; ++k) {
      const int a = i + di[k], b = j + dj[k];
      if (a < 0 || b < 0 || a >= dem.nx || b >= dem.ny) continue;
      const float z = dem.at(a, b);
      if (std::isnan(z)) continue;
      const double nh = h - tan_angle * dist[k];
      const size_t nc = static_cast<size_t>(b) * dem.nx + a;
      if (nh >= z && nh > head[nc]) {
        head[nc] = nh;
        queue.push({nh, nc});
      }
    }
  }
  std::vector<char> reached(n, 0);
  max_energy_height = 0.0;
  for (size_t c = 0; c < n; ++c) {
    reached[c] = std::isfinite(head[c]) ? 1 : 0;
    if (reached[c]) max_energy_height = std::max(max_energy_height, head[c] - dem.values[c]);
  }
  return reached;
}

// Widens a mask by a distance (disc stamped at every edge cell).
void dilate(const Grid& g, std::vector<char>& mask, double radius) {
  const int rx = static_cast<int>(std::ceil(radius / g.dx)), ry = static_cast<int>(std::ceil(radius / g.dy));
  std::vector<std::pair<int, int>> disc;
  for (int b = -ry; b <= ry; ++b)
    for (int a = -rx; a <= rx; ++a)
      if (std::hypot(a * g.dx, b * g.dy) <= radius + 1e-9) disc.push_back({a, b});
  std::vector<char> out = mask;
  for (int j = 0; j < g.ny; ++j) {
    for (int i = 0; i < g.nx; ++i) {
      if (!mask[static_cast<size_t>(j) * g.nx + i]) continue;
      bool edge = false;
      for (int k = 0; k < 4 && !edge; ++k) {
        const int a = i + (k == 0) - (k == 1), b = j + (k == 2) - (k == 3);
        edge = a < 0 || b < 0 || a >= g.nx || b >= g.ny || !mask[static_cast<size_t>(b) * g.nx + a];
      }
      if (!edge) continue;
      for (const auto& [a, b] : disc) {
        const int x = i + a, y = j + b;
        if (x >= 0 && y >= 0 && x < g.nx && y < g.ny) out[static_cast<size_t>(y) * g.nx + x] = 1;
      }
    }
  }
  mask.swap(out);
}

// Footprint test of a structure at a map point (walls widened to at least `layers` particle columns).
struct Footprint {
  const StructureSpec* s;
  double half_wall;
  std::vector<Polyline> walled_edges;  // basins
  bool contains(double x, double y) const {
    if (s->kind == StructureKind::check_dam) return distance_to_polyline(s->line, x, y) <= half_wall;
    if (inside_polygon(s->line, x, y)) return true;
    for (const auto& e : walled_edges)
      if (distance_to_polyline(e, x, y) <= half_wall) return true;
    return false;
  }
  double reach() const { return half_wall; }
};

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
  if (p[2] < b - dp) {
    s << "is below the terrain at map " << point(mx, my) << ": z = " << p[2] << " m, ground " << b << " m";
    return s.str();
  }
  const size_t c = static_cast<size_t>(j) * bed.nx + i;
  if (!wall_interior.empty() && wall_interior[c] && p[2] < wall_top.at(i, j) - dp) {
    s << "is inside the wall of '" << structures[wall_owner[c]].name << "' at map " << point(mx, my)
      << ", z = " << p[2] << " m";
    return s.str();
  }
  return {};
}

TerrainModel build_terrain(const TerrainSpec& spec, double dp, long max_particles) {
  if (!(dp > 0)) throw TerrainError("dp", "must be > 0");
  TerrainModel m;
  m.dp = dp;
  m.dem = load_dem(spec.dem_path, spec.dem);
  const Grid& dem = m.dem;

  // Inputs against the DEM, before any work.
  if (spec.release.polygon.size() < 3) throw TerrainError("release.polygon", "needs at least 3 vertices");
  require_inside_dem(dem, spec.release.polygon, "release.polygon", "the release");
  const double release_area = polygon_area(spec.release.polygon);
  if (!(release_area > 0)) throw TerrainError("release.polygon", "has zero area");
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    const std::string field = structure_field(k, s.name);
    const size_t need = s.kind == StructureKind::check_dam ? 2 : 3;
    if (s.line.size() < need)
      throw TerrainError(field, "'" + s.name + "' needs at least " + std::to_string(need) + " vertices");
    require_inside_dem(dem, s.line, field, "'" + s.name + "'");
    if (s.kind != StructureKind::check_dam && !(polygon_area(s.line) > 0))
      throw TerrainError(field, "'" + s.name + "' has zero area");
  }
  for (size_t k = 0; k < spec.protected_zones.size(); ++k)
    if (spec.protected_zones[k].polygon.size() < 3)
      throw TerrainError("protected_zones[" + std::to_string(k) + "].polygon", "needs at least 3 vertices");

  // Footprints (walls at least `layers` columns thick, so the flow cannot pass between their particles).
  const double min_half_wall = 0.5 * spec.layers * dp + 1e-9;
  std::vector<Footprint> feet;
  for (const auto& s : spec.structures) {
    Footprint f{&s, 0.0, {}};
    if (s.kind == StructureKind::check_dam) f.half_wall = std::max(0.5 * s.thickness, min_half_wall);
    if (s.kind == StructureKind::retention_basin && s.wall_height > 0) {
      f.half_wall = std::max(0.5 * s.wall_thickness, min_half_wall);
      const size_t n = s.line.size();
      std::vector<int> open;
      if (s.open_edges) {
        open = *s.open_edges;
      } else {  // the edge whose midpoint is highest is where the flow comes in
        int best = 0;
        double best_z = -1e300;
        for (size_t e = 0; e < n; ++e) {
          const auto& a = s.line[e];
          const auto& b = s.line[(e + 1) % n];
          const double z = dem.sample(0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]));
          if (z > best_z) best_z = z, best = static_cast<int>(e);
        }
        open = {best};
      }
      for (size_t e = 0; e < n; ++e)
        if (std::find(open.begin(), open.end(), static_cast<int>(e)) == open.end())
          f.walled_edges.push_back({s.line[e], s.line[(e + 1) % n]});
    }
    feet.push_back(std::move(f));
  }

  // Corridor on DEM cells.
  const size_t ncell = dem.values.size();
  std::vector<char> corridor(ncell, 0);
  double release_depth = spec.release.depth;
  if (!(release_depth > 0)) release_depth = spec.release.volume / release_area;
  const double buffer = spec.corridor.buffer_m > 0 ? spec.corridor.buffer_m : std::max(20.0, 10.0 * dp);
  {
    // The energy-line reach is computed even when a polygon sets the corridor: its energy height gives the
    // speed scale for the default speed of sound.
    std::vector<std::pair<size_t, double>> sources;
    auto add_source = [&](int i, int j) {
      const float z = dem.at(i, j);
      if (!std::isnan(z)) sources.push_back({static_cast<size_t>(j) * dem.nx + i, z + release_depth});
    };
    for (int j = 0; j < dem.ny; ++j)
      for (int i = 0; i < dem.nx; ++i)
        if (inside_polygon(spec.release.polygon, dem.cx(i), dem.cy(j))) add_source(i, j);
    for (const auto& v : spec.release.polygon) {  // a release smaller than a DEM cell still has a source
      int i, j;
      if (dem.cell_of(v[0], v[1], i, j)) add_source(i, j);
    }
    corridor = energy_line_reach(dem, sources, std::tan(spec.corridor.travel_angle_deg * kPi / 180.0),
                                 m.max_energy_height);
    m.max_energy_height = std::max(m.max_energy_height, release_depth);
    if (spec.corridor.polygon.empty()) {
      dilate(dem, corridor, buffer);
    } else {
      for (int j = 0; j < dem.ny; ++j)
        for (int i = 0; i < dem.nx; ++i)
          corridor[static_cast<size_t>(j) * dem.nx + i] = inside_polygon(spec.corridor.polygon, dem.cx(i), dem.cy(j));
    }
  }
  // A structure the user placed is modelled even where the reach does not go.
  for (const auto& f : feet) {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (const auto& p : f.s->line) x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
    const double r = f.reach() + std::max(dem.dx, dem.dy);
    Polyline ring = f.s->line;  // the polygon's outline, closed
    ring.push_back(ring.front());
    for (int j = 0; j < dem.ny; ++j) {
      if (dem.cy(j) < y0 - r || dem.cy(j) > y1 + r) continue;
      for (int i = 0; i < dem.nx; ++i) {
        if (dem.cx(i) < x0 - r || dem.cx(i) > x1 + r) continue;
        const double d = f.s->kind == StructureKind::check_dam ? distance_to_polyline(f.s->line, dem.cx(i), dem.cy(j))
                         : inside_polygon(f.s->line, dem.cx(i), dem.cy(j)) ? 0.0
                                                                          : distance_to_polyline(ring, dem.cx(i), dem.cy(j));
        if (d <= r) corridor[static_cast<size_t>(j) * dem.nx + i] = 1;
      }
    }
  }
  size_t valid = 0, kept = 0;
  int ci0 = dem.nx, ci1 = -1, cj0 = dem.ny, cj1 = -1;
  for (int j = 0; j < dem.ny; ++j) {
    for (int i = 0; i < dem.nx; ++i) {
      const size_t c = static_cast<size_t>(j) * dem.nx + i;
      if (std::isnan(dem.values[c])) {
        corridor[c] = 0;
        continue;
      }
      ++valid;
      if (!corridor[c]) continue;
      ++kept;
      ci0 = std::min(ci0, i), ci1 = std::max(ci1, i), cj0 = std::min(cj0, j), cj1 = std::max(cj1, j);
    }
  }
  if (kept == 0) throw TerrainError("release.polygon", "lies on DEM nodata: no cell of the corridor has data");
  m.corridor_area = kept * dem.cell_area();
  m.max_corridor_outflow = spec.corridor.max_outflow;
  m.modelled_fraction = static_cast<double>(kept) / static_cast<double>(valid);

  // Bed grid at dp over the corridor's bounding box.
  const double bx0 = dem.x0 + ci0 * dem.dx, bx1 = dem.x0 + (ci1 + 1) * dem.dx;
  const double by0 = dem.y0 - cj0 * dem.dy, by1 = dem.y0 - (cj1 + 1) * dem.dy;  // north, south edges
  const int nx = static_cast<int>(std::ceil((bx1 - bx0) / dp - 1e-9));
  const int ny = static_cast<int>(std::ceil((by0 - by1) / dp - 1e-9));
  if (static_cast<double>(nx) * ny * spec.layers > 4.0 * max_particles)
    throw TerrainError("dp", "dp = " + num(dp) + " m makes a " + std::to_string(nx) + " x " + std::to_string(ny) +
                                 " column grid over the corridor, more than limits.max_particles = " +
                                 std::to_string(max_particles) + " allows: raise dp or narrow the corridor");
  m.original = Grid(nx, ny, bx0, by0, dp, dp, dem.crs_wkt, Grid::nodata);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      int a, b;
      double x = m.original.cx(i), y = m.original.cy(j);
      // The dp grid rounds the corridor's box up to whole dp, so its last column or row may stick out of the
      // DEM by less than dp: that strip takes the edge cell's ground (without it the flow met a gap with no
      // ground at the DEM's edge instead of the outflow face).
      x = std::clamp(x, bx0 + 1e-9 * dem.dx, bx1 - 1e-9 * dem.dx);
      y = std::clamp(y, by1 + 1e-9 * dem.dy, by0 - 1e-9 * dem.dy);
      if (!dem.cell_of(x, y, a, b) || !corridor[static_cast<size_t>(b) * dem.nx + a]) continue;
      double z = dem.sample(x, y);
      if (std::isnan(z)) z = dem.at(a, b);  // next to nodata: the cell's own value
      m.original.at(i, j) = static_cast<float>(z);
    }
  }
  m.origin_x = bx0;
  m.origin_y = by1;
  m.open_faces[0][0] = ci0 == 0;
  m.open_faces[0][1] = ci1 == dem.nx - 1;
  m.open_faces[1][0] = cj1 == dem.ny - 1;  // south
  m.open_faces[1][1] = cj0 == 0;           // north
  Grid& bed = m.bed;
  bed = m.original;
  const size_t ncol = bed.values.size();
  auto col = [&](int i, int j) { return static_cast<size_t>(j) * nx + i; };

  // Release columns must all have ground.
  std::vector<size_t> release_cols;
  size_t release_nodata = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      if (inside_polygon(spec.release.polygon, bed.cx(i), bed.cy(j))) {
        if (std::isnan(bed.at(i, j))) ++release_nodata;
        else release_cols.push_back(col(i, j));
      }
  if (release_nodata > 0)
    throw TerrainError("release.polygon", std::to_string(release_nodata) + " of " +
                                              std::to_string(release_nodata + release_cols.size()) +
                                              " dp x dp columns under the release have no DEM data (nodata)");
  if (release_cols.empty())
    throw TerrainError("release.polygon", "encloses no dp x dp column (dp = " + num(dp) + " m): enlarge it or lower dp");

  // Footprints on the bed grid; two structures may not share a column.
  std::vector<int> owner(ncol, -1);
  for (size_t k = 0; k < feet.size(); ++k) {
    size_t count = 0, nodata = 0;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!feet[k].contains(bed.cx(i), bed.cy(j))) continue;
        const size_t c = col(i, j);
        if (std::isnan(bed.values[c])) {
          ++nodata;
          continue;
        }
        if (owner[c] >= 0)
          throw TerrainError(structure_field(k, spec.structures[k].name),
                             "'" + spec.structures[k].name + "' overlaps structures[" + std::to_string(owner[c]) +
                                 "] ('" + spec.structures[owner[c]].name + "') at map " +
                                 point(bed.cx(i), bed.cy(j)) + ": structures must not overlap");
        owner[c] = static_cast<int>(k);
        ++count;
      }
    if (nodata > 0)
      throw TerrainError(structure_field(k, spec.structures[k].name),
                         "'" + spec.structures[k].name + "' lies partly on DEM nodata (" + std::to_string(nodata) + " columns)");
    if (count == 0)
      throw TerrainError(structure_field(k, spec.structures[k].name),
                         "'" + spec.structures[k].name + "' covers no dp x dp column at dp = " + num(dp) + " m");
  }

  // Regrading and excavation.
  m.wall_top = bed.like(Grid::nodata);
  m.wall_owner.assign(ncol, -1);
  uint32_t next_tag = 2;
  const double cell = dp * dp;
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    StructureInfo info;
    info.name = s.name;
    info.kind = s.kind;
    info.outline = s.line;
    if (s.kind == StructureKind::deposition_area) {
      // Plane fit of the ground inside gives its mean downhill direction.
      std::vector<size_t> cols;
      double sx = 0, sy = 0, sz = 0;
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          if (owner[col(i, j)] == static_cast<int>(k)) {
            cols.push_back(col(i, j));
            sx += bed.cx(i), sy += bed.cy(j), sz += bed.at(i, j);
          }
      const double n = static_cast<double>(cols.size());
      const double mx = sx / n, my = sy / n, mz = sz / n;
      double sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0;
      for (size_t c : cols) {
        const double x = bed.cx(static_cast<int>(c % nx)) - mx, y = bed.cy(static_cast<int>(c / nx)) - my,
                     z = bed.values[c] - mz;
        sxx += x * x, sxy += x * y, syy += y * y, sxz += x * z, syz += y * z;
      }
      const double det = sxx * syy - sxy * sxy;
      double gx = 0, gy = 0;  // ground gradient dz/dx, dz/dy
      if (std::abs(det) > 1e-12) {
        gx = (sxz * syy - syz * sxy) / det;
        gy = (syz * sxx - sxz * sxy) / det;
      }
      const double gnorm = std::hypot(gx, gy);
      const double ux = gnorm > 0 ? -gx / gnorm : 0.0, uy = gnorm > 0 ? -gy / gnorm : 0.0;  // downhill
      const double e0 = s.elevation ? *s.elevation : mz;
      for (size_t c : cols) {
        const double x = bed.cx(static_cast<int>(c % nx)) - mx, y = bed.cy(static_cast<int>(c / nx)) - my;
        const double znew = e0 - s.gradient * (ux * x + uy * y);
        const double dz = znew - bed.values[c];
        (dz > 0 ? info.fill_volume : info.cut_volume) += std::abs(dz) * cell;
        bed.values[c] = static_cast<float>(znew);
      }
    } else if (s.kind == StructureKind::retention_basin) {
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          if (owner[col(i, j)] == static_cast<int>(k) && inside_polygon(s.line, bed.cx(i), bed.cy(j))) {
            bed.at(i, j) -= static_cast<float>(s.depth);
            info.cut_volume += s.depth * cell;
          }
    }
    m.structures.push_back(std::move(info));
  }

  // Walls: check dams and basin walls.
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    auto& info = m.structures[k];
    const auto& f = feet[k];
    if (s.kind == StructureKind::deposition_area) continue;
    if (s.kind == StructureKind::retention_basin && !(s.wall_height > 0)) continue;
    info.tag = next_tag++;
    double crest = 0.0, thalweg_z = 1e300, thalweg_s = 0.0;
    if (s.kind == StructureKind::check_dam) {
      double length = 0, s0 = 0;
      for (size_t e = 0; e + 1 < s.line.size(); ++e)
        length += std::hypot(s.line[e + 1][0] - s.line[e][0], s.line[e + 1][1] - s.line[e][1]);
      for (size_t e = 0; e + 1 < s.line.size(); ++e) {  // the lowest bed point along the axis
        const double ex = s.line[e + 1][0] - s.line[e][0], ey = s.line[e + 1][1] - s.line[e][1];
        const double len = std::hypot(ex, ey);
        const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.25 * dp))));
        for (int q = 0; q <= steps; ++q) {
          const double t = static_cast<double>(q) / steps;
          int i, j;
          if (!bed.cell_of(s.line[e][0] + t * ex, s.line[e][1] + t * ey, i, j)) continue;
          // The DEM itself, not the dp lattice: a dam owns its columns, so its ground is never regraded, and
          // the lattice would miss a V-shaped thalweg by up to half a spacing.
          const double z = dem.sample(s.line[e][0] + t * ex, s.line[e][1] + t * ey);
          if (!std::isnan(z) && z < thalweg_z) thalweg_z = z, thalweg_s = s0 + t * len;
        }
        s0 += len;
      }
      (void)length;
      crest = thalweg_z + s.crest_height;
      info.crest_elevation = crest;
      info.wall_height_built = s.crest_height;
    }
    double lowest_top = 1e300;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const size_t c = col(i, j);
        if (owner[c] != static_cast<int>(k)) continue;
        double top;
        if (s.kind == StructureKind::check_dam) {
          double along;
          distance_to_polyline(s.line, bed.cx(i), bed.cy(j), &along);
          top = crest;
          if (s.slit_width > 0 && std::abs(along - thalweg_s) <= 0.5 * s.slit_width)
            top = thalweg_z + s.slit_bottom;
        } else {
          // The wall's crest is level across its thickness: the ground on its axis (the nearest walled edge)
          // plus the wall height.
          const Polyline* nearest = nullptr;
          double best = 1e300;
          for (const auto& e : f.walled_edges) {
            const double d = distance_to_polyline(e, bed.cx(i), bed.cy(j));
            if (d < best) best = d, nearest = &e;
          }
          if (!nearest || best > f.half_wall) continue;
          double along;
          distance_to_polyline(*nearest, bed.cx(i), bed.cy(j), &along);
          const auto& a = (*nearest)[0];
          const auto& bpt = (*nearest)[1];
          const double len = std::hypot(bpt[0] - a[0], bpt[1] - a[1]);
          const double t = len > 0 ? along / len : 0.0;
          double ground = dem.sample(a[0] + t * (bpt[0] - a[0]), a[1] + t * (bpt[1] - a[1]));
          if (std::isnan(ground)) ground = m.original.at(i, j);
          top = ground + s.wall_height;
          lowest_top = std::min(lowest_top, top);
        }
        if (top > bed.values[c] + 0.5 * dp) {
          m.wall_top.values[c] = static_cast<float>(top);
          m.wall_owner[c] = static_cast<int>(k);
        }
      }
    if (s.kind == StructureKind::retention_basin) {
      info.crest_elevation = lowest_top;
      info.wall_height_built = s.wall_height;
    }
  }
  m.wall_interior.assign(ncol, 0);
  for (int j = 1; j + 1 < ny; ++j)
    for (int i = 1; i + 1 < nx; ++i) {
      const size_t c = col(i, j);
      m.wall_interior[c] = m.wall_owner[c] >= 0 && m.wall_owner[c - 1] >= 0 && m.wall_owner[c + 1] >= 0 &&
                           m.wall_owner[c - nx] >= 0 && m.wall_owner[c + nx] >= 0;
    }

  // Storage capacity: the volume below the structure's overflow level that it holds back.
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    auto& info = m.structures[k];
    if (s.kind == StructureKind::check_dam) {
      // Flood from the upstream face through columns below the crest, staying on the upstream side.
      auto side = [&](double x, double y) {
        double best = 1e300, sgn = 0;
        for (size_t e = 0; e + 1 < s.line.size(); ++e) {
          const Polyline seg{s.line[e], s.line[e + 1]};
          const double d = distance_to_polyline(seg, x, y);
          if (d < best) {
            best = d;
            const double ex = s.line[e + 1][0] - s.line[e][0], ey = s.line[e + 1][1] - s.line[e][1];
            sgn = ex * (y - s.line[e][1]) - ey * (x - s.line[e][0]) > 0 ? 1.0 : -1.0;
          }
        }
        return sgn;
      };
      double zl = 0, zr = 0;
      int nl = 0, nr = 0;
      for (size_t c = 0; c < ncol; ++c) {
        if (owner[c] >= 0 || std::isnan(bed.values[c])) continue;
        const double x = bed.cx(static_cast<int>(c % nx)), y = bed.cy(static_cast<int>(c / nx));
        const double d = distance_to_polyline(s.line, x, y);
        if (d > feet[k].half_wall + 3 * dp) continue;
        (side(x, y) > 0 ? (zl += bed.values[c], ++nl) : (zr += bed.values[c], ++nr));
      }
      const double up = (nl ? zl / nl : -1e300) > (nr ? zr / nr : -1e300) ? 1.0 : -1.0;
      {  // downstream normal: away from the upstream side of the axis (its end-to-end direction)
        const double ex = s.line.back()[0] - s.line.front()[0], ey = s.line.back()[1] - s.line.front()[1];
        const double len = std::hypot(ex, ey);
        if (len > 0) info.flow_normal = {up * ey / len, -up * ex / len};
      }
      std::vector<char> seen(ncol, 0);
      std::vector<size_t> stack;
      for (size_t c = 0; c < ncol; ++c) {
        if (owner[c] >= 0 || std::isnan(bed.values[c]) || bed.values[c] >= info.crest_elevation) continue;
        const double x = bed.cx(static_cast<int>(c % nx)), y = bed.cy(static_cast<int>(c / nx));
        if (distance_to_polyline(s.line, x, y) <= feet[k].half_wall + 1.5 * dp && side(x, y) == up) {
          seen[c] = 1;
          stack.push_back(c);
        }
      }
      while (!stack.empty()) {
        const size_t c = stack.back();
        stack.pop_back();
        info.storage_capacity += (info.crest_elevation - bed.values[c]) * cell;
        const int i = static_cast<int>(c % nx), j = static_cast<int>(c / nx);
        const int ni[4] = {i + 1, i - 1, i, i}, nj[4] = {j, j, j + 1, j - 1};
        for (int q = 0; q < 4; ++q) {
          if (ni[q] < 0 || nj[q] < 0 || ni[q] >= nx || nj[q] >= ny) continue;
          const size_t n = col(ni[q], nj[q]);
          if (seen[n] || owner[n] >= 0 || std::isnan(bed.values[n]) || bed.values[n] >= info.crest_elevation) continue;
          if (side(bed.cx(ni[q]), bed.cy(nj[q])) != up) continue;
          seen[n] = 1;
          stack.push_back(n);
        }
      }
    } else if (s.kind == StructureKind::retention_basin) {
      // Overflow level: the lowest of the wall tops and of the ground along the open edges.
      double level = info.tag ? info.crest_elevation : 1e300;
      const size_t n = s.line.size();
      for (size_t e = 0; e < n; ++e) {
        const Polyline edge{s.line[e], s.line[(e + 1) % n]};
        bool walled = false;
        for (const auto& w : feet[k].walled_edges) walled = walled || (w[0] == edge[0] && w[1] == edge[1]);
        if (walled) continue;
        const double len = std::hypot(edge[1][0] - edge[0][0], edge[1][1] - edge[0][1]);
        const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.5 * dp))));
        for (int q = 0; q <= steps; ++q) {
          const double t = static_cast<double>(q) / steps;
          const double z = m.original.sample(edge[0][0] + t * (edge[1][0] - edge[0][0]),
                                             edge[0][1] + t * (edge[1][1] - edge[0][1]));
          if (!std::isnan(z)) level = std::min(level, z);
        }
      }
      info.crest_elevation = level;
      {  // the flow enters over the open edges and pushes the walls away from them
        double cx = 0, cy = 0, ox = 0, oy = 0;
        int no = 0;
        for (const auto& p : s.line) cx += p[0] / n, cy += p[1] / n;
        for (size_t e = 0; e < n; ++e) {
          const Polyline edge{s.line[e], s.line[(e + 1) % n]};
          bool walled = false;
          for (const auto& w : feet[k].walled_edges) walled = walled || (w[0] == edge[0] && w[1] == edge[1]);
          if (!walled) ox += 0.5 * (edge[0][0] + edge[1][0]), oy += 0.5 * (edge[0][1] + edge[1][1]), ++no;
        }
        if (no) {
          const double dx = cx - ox / no, dy = cy - oy / no, len = std::hypot(dx, dy);
          if (len > 0) info.flow_normal = {dx / len, dy / len};
        }
      }
      for (size_t c = 0; c < ncol; ++c)
        if (owner[c] == static_cast<int>(k) && m.wall_owner[c] < 0 &&
            inside_polygon(s.line, bed.cx(static_cast<int>(c % nx)), bed.cy(static_cast<int>(c / nx))))
          info.storage_capacity += std::max(0.0, level - bed.values[c]) * cell;
    }
  }

  // Boundary particles: each column gets `layers` under its surface, more where a neighbour is lower (steep
  // ground), so the sheet has no holes; wall columns get the wall on top.
  size_t estimate = 0;
  std::vector<int> depth_count(ncol, 0);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const size_t c = col(i, j);
      const double b = bed.values[c];
      if (std::isnan(b)) continue;
      double lowest = b;
      for (int q = -1; q <= 1; ++q)
        for (int r = -1; r <= 1; ++r) {
          const int a = i + q, bb = j + r;
          if (a < 0 || bb < 0 || a >= nx || bb >= ny) continue;
          const double z = bed.at(a, bb);
          if (!std::isnan(z)) lowest = std::min(lowest, z);
        }
      depth_count[c] = spec.layers + static_cast<int>(std::ceil(std::max(0.0, b - lowest) / dp - 1e-9));
      estimate += depth_count[c];
      if (!std::isnan(m.wall_top.values[c]))
        estimate += static_cast<size_t>(std::max(0.0, std::round((m.wall_top.values[c] - b) / dp)));
    }
  const double layers_est = std::ceil(release_depth / dp);
  estimate += static_cast<size_t>(release_cols.size() * std::max(1.0, layers_est));
  if (estimate > static_cast<size_t>(max_particles))
    throw TerrainError("dp", "dp = " + num(dp) + " m gives about " + std::to_string(estimate) +
                                 " particles, over limits.max_particles = " + std::to_string(max_particles));
  m.boundary.reserve(estimate);
  m.boundary_tag.reserve(estimate);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const size_t c = col(i, j);
      const double b = bed.values[c];
      if (std::isnan(b)) continue;
      const double x = bed.cx(i) - m.origin_x, y = bed.cy(j) - m.origin_y;
      for (int q = 0; q < depth_count[c]; ++q) {
        m.boundary.push_back(Vec<3>(x, y, b - (q + 0.5) * dp));
        m.boundary_tag.push_back(1);
      }
      if (!std::isnan(m.wall_top.values[c])) {
        const int n = static_cast<int>(std::round((m.wall_top.values[c] - b) / dp));
        const uint32_t tag = m.structures[m.wall_owner[c]].tag;
        for (int q = 0; q < n; ++q) {
          m.boundary.push_back(Vec<3>(x, y, b + (q + 0.5) * dp));
          m.boundary_tag.push_back(tag);
        }
      }
    }

  // Release: columns of fluid on the bed.
  const int nlayers =
      std::max(1, static_cast<int>(std::lround(spec.release.depth > 0
                                                   ? spec.release.depth / dp
                                                   : spec.release.volume / (release_cols.size() * cell * dp))));
  for (size_t c : release_cols) {
    if (m.wall_owner[c] >= 0)
      throw TerrainError("release.polygon", "overlaps the wall of '" + m.structures[m.wall_owner[c]].name +
                                                "': the release must start outside structures");
    const int i = static_cast<int>(c % nx), j = static_cast<int>(c / nx);
    const double b = bed.values[c];
    for (int q = 0; q < nlayers; ++q) {
      m.fluid.push_back(Vec<3>(bed.cx(i) - m.origin_x, bed.cy(j) - m.origin_y, b + (q + 0.5) * dp));
      m.fluid_depth.push_back((nlayers - q - 0.5) * dp);
    }
  }
  m.release_depth = nlayers * dp;
  m.release_volume = static_cast<double>(m.fluid.size()) * cell * dp;
  m.release_polygon = spec.release.polygon;
  m.protected_zones = spec.protected_zones;
  return m;
}

}  // namespace runout::terrain
