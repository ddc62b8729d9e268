// Structures on the bed grid: their footprints, the ground they regrade or excavate, their walls, and the
// volume they can store.
#include <algorithm>
#include <cmath>

#include "build_steps.hpp"
#include "runout/engine/geometry.hpp"

namespace runout::terrain::detail {
namespace {

size_t column(const Grid& bed, int i, int j) { return static_cast<size_t>(j) * bed.nx + i; }

// A basin's open edges: as given, or the edge whose midpoint is highest, where the flow comes in.
std::vector<int> open_edges(const StructureSpec& s, const Grid& dem) {
  if (s.open_edges) return *s.open_edges;
  const size_t n = s.line.size();
  int best = 0;
  double best_z = -1e300;
  for (size_t e = 0; e < n; ++e) {
    const auto& a = s.line[e];
    const auto& b = s.line[(e + 1) % n];
    const double z = dem.sample(0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]));
    if (z > best_z) best_z = z, best = static_cast<int>(e);
  }
  return {best};
}

// Deposition area: the bed inside becomes a plane through its centroid, falling along the mean downhill
// direction that a plane fit of the ground inside gives.
void regrade_deposition_area(Grid& bed, const std::vector<int>& owner, int k, const StructureSpec& s, double cell,
                             StructureInfo& info) {
  const int nx = bed.nx, ny = bed.ny;
  std::vector<size_t> cols;
  double sx = 0, sy = 0, sz = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      if (owner[column(bed, i, j)] == k) {
        cols.push_back(column(bed, i, j));
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
}

// Raises the wall on column c to `top` where that is more than half a spacing above the bed.
void raise_wall(TerrainModel& m, size_t c, int k, double top) {
  if (top > m.bed.values[c] + 0.5 * m.dp) {
    m.wall_top.values[c] = static_cast<float>(top);
    m.wall_owner[c] = k;
  }
}

// Check dam: its crest stands crest_height over the lowest ground on its axis (the thalweg), its slit (if
// any) slit_bottom over it.
void build_dam_wall(TerrainModel& m, const StructureSpec& s, int k, const std::vector<int>& owner) {
  const Grid& bed = m.bed;
  auto& info = m.structures[k];
  double thalweg_z = 1e300, thalweg_s = 0.0, s0 = 0;
  for (size_t e = 0; e + 1 < s.line.size(); ++e) {  // the lowest bed point along the axis
    const double ex = s.line[e + 1][0] - s.line[e][0], ey = s.line[e + 1][1] - s.line[e][1];
    const double len = std::hypot(ex, ey);
    const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.25 * m.dp))));
    for (int q = 0; q <= steps; ++q) {
      const double t = static_cast<double>(q) / steps;
      int i, j;
      if (!bed.cell_of(s.line[e][0] + t * ex, s.line[e][1] + t * ey, i, j)) continue;
      // The DEM itself, not the dp lattice: a dam owns its columns, so its ground is never regraded, and
      // the lattice would miss a V-shaped thalweg by up to half a spacing.
      const double z = m.dem.sample(s.line[e][0] + t * ex, s.line[e][1] + t * ey);
      if (!std::isnan(z) && z < thalweg_z) thalweg_z = z, thalweg_s = s0 + t * len;
    }
    s0 += len;
  }
  const double crest = thalweg_z + s.crest_height;
  info.crest_elevation = crest;
  info.wall_height_built = s.crest_height;
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i) {
      const size_t c = column(bed, i, j);
      if (owner[c] != k) continue;
      double along;
      distance_to_polyline(s.line, bed.cx(i), bed.cy(j), &along);
      double top = crest;
      if (s.slit_width > 0 && std::abs(along - thalweg_s) <= 0.5 * s.slit_width) top = thalweg_z + s.slit_bottom;
      raise_wall(m, c, k, top);
    }
}

// Basin walls: the crest is level across the wall's thickness, the ground on its axis (the nearest walled
// edge) plus the wall height. The basin's crest elevation is the lowest wall top.
void build_basin_walls(TerrainModel& m, const StructureSpec& s, const Footprint& f, int k,
                       const std::vector<int>& owner) {
  const Grid& bed = m.bed;
  double lowest_top = 1e300;
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i) {
      const size_t c = column(bed, i, j);
      if (owner[c] != k) continue;
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
      double ground = m.dem.sample(a[0] + t * (bpt[0] - a[0]), a[1] + t * (bpt[1] - a[1]));
      if (std::isnan(ground)) ground = m.original.at(i, j);
      const double top = ground + s.wall_height;
      lowest_top = std::min(lowest_top, top);
      raise_wall(m, c, k, top);
    }
  m.structures[k].crest_elevation = lowest_top;
  m.structures[k].wall_height_built = s.wall_height;
}

// +1/-1 by the side of a dam's axis a map point is on (of the segment nearest to it); a point exactly on the
// axis counts as -1.
double axis_side(const Polyline& line, double x, double y) {
  SegmentRules rules;
  rules.on_line_side = -1;
  return nearest_segment(line, x, y, rules).side;
}

// A dam's upstream side: the side of its axis whose ground next to the dam is higher on average.
double upstream_side(const Grid& bed, const StructureSpec& s, const Footprint& f, const std::vector<int>& owner,
                     double dp) {
  double zl = 0, zr = 0;
  int nl = 0, nr = 0;
  for (size_t c = 0; c < bed.values.size(); ++c) {
    if (owner[c] >= 0 || std::isnan(bed.values[c])) continue;
    const double x = bed.cx(static_cast<int>(c % bed.nx)), y = bed.cy(static_cast<int>(c / bed.nx));
    const double d = distance_to_polyline(s.line, x, y);
    if (d > f.half_wall + 3 * dp) continue;
    (axis_side(s.line, x, y) > 0 ? (zl += bed.values[c], ++nl) : (zr += bed.values[c], ++nr));
  }
  return (nl ? zl / nl : -1e300) > (nr ? zr / nr : -1e300) ? 1.0 : -1.0;
}

// Check dam: flood from the upstream face through columns below the crest, staying on the upstream side.
void dam_storage(const Grid& bed, const StructureSpec& s, const Footprint& f, const std::vector<int>& owner,
                 double dp, StructureInfo& info) {
  const int nx = bed.nx, ny = bed.ny;
  const double cell = dp * dp;
  const double up = upstream_side(bed, s, f, owner, dp);
  {  // downstream normal: away from the upstream side of the axis (its end-to-end direction)
    const double ex = s.line.back()[0] - s.line.front()[0], ey = s.line.back()[1] - s.line.front()[1];
    const double len = std::hypot(ex, ey);
    if (len > 0) info.flow_normal = {up * ey / len, -up * ex / len};
  }
  std::vector<char> seen(bed.values.size(), 0);
  std::vector<size_t> stack;
  for (size_t c = 0; c < bed.values.size(); ++c) {
    if (owner[c] >= 0 || std::isnan(bed.values[c]) || bed.values[c] >= info.crest_elevation) continue;
    const double x = bed.cx(static_cast<int>(c % nx)), y = bed.cy(static_cast<int>(c / nx));
    if (distance_to_polyline(s.line, x, y) <= f.half_wall + 1.5 * dp && axis_side(s.line, x, y) == up) {
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
      const size_t n = column(bed, ni[q], nj[q]);
      if (seen[n] || owner[n] >= 0 || std::isnan(bed.values[n]) || bed.values[n] >= info.crest_elevation) continue;
      if (axis_side(s.line, bed.cx(ni[q]), bed.cy(nj[q])) != up) continue;
      seen[n] = 1;
      stack.push_back(n);
    }
  }
}

// Retention basin: what it holds below its overflow level, the lowest of the wall tops and of the ground
// along the open edges.
void basin_storage(const TerrainModel& m, const StructureSpec& s, const Footprint& f, int k,
                   const std::vector<int>& owner, StructureInfo& info) {
  const Grid& bed = m.bed;
  const double dp = m.dp, cell = dp * dp;
  double level = info.tag ? info.crest_elevation : 1e300;
  const size_t n = s.line.size();
  for (size_t e = 0; e < n; ++e) {
    const Polyline edge{s.line[e], s.line[(e + 1) % n]};
    if (f.walled(edge)) continue;
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
      if (!f.walled(edge)) ox += 0.5 * (edge[0][0] + edge[1][0]), oy += 0.5 * (edge[0][1] + edge[1][1]), ++no;
    }
    if (no) {
      const double dx = cx - ox / no, dy = cy - oy / no, len = std::hypot(dx, dy);
      if (len > 0) info.flow_normal = {dx / len, dy / len};
    }
  }
  for (size_t c = 0; c < bed.values.size(); ++c)
    if (owner[c] == k && m.wall_owner[c] < 0 &&
        inside_polygon(s.line, bed.cx(static_cast<int>(c % bed.nx)), bed.cy(static_cast<int>(c / bed.nx))))
      info.storage_capacity += std::max(0.0, level - bed.values[c]) * cell;
}

}  // namespace

bool Footprint::contains(double x, double y) const {
  if (s->kind == StructureKind::check_dam) return distance_to_polyline(s->line, x, y) <= half_wall;
  if (inside_polygon(s->line, x, y)) return true;
  for (const auto& e : walled_edges)
    if (distance_to_polyline(e, x, y) <= half_wall) return true;
  return false;
}

bool Footprint::walled(const Polyline& edge) const {
  bool found = false;
  for (const auto& w : walled_edges) found = found || (w[0] == edge[0] && w[1] == edge[1]);
  return found;
}

std::vector<Footprint> footprints(const TerrainSpec& spec, const Grid& dem, double dp) {
  // Walls at least `layers` columns thick, so the flow cannot pass between their particles.
  const double min_half_wall = 0.5 * spec.layers * dp + 1e-9;
  std::vector<Footprint> feet;
  for (const auto& s : spec.structures) {
    Footprint f{&s, 0.0, {}};
    if (s.kind == StructureKind::check_dam) f.half_wall = std::max(0.5 * s.thickness, min_half_wall);
    if (s.kind == StructureKind::retention_basin && s.wall_height > 0) {
      f.half_wall = std::max(0.5 * s.wall_thickness, min_half_wall);
      const size_t n = s.line.size();
      const std::vector<int> open = open_edges(s, dem);
      for (size_t e = 0; e < n; ++e)
        if (std::find(open.begin(), open.end(), static_cast<int>(e)) == open.end())
          f.walled_edges.push_back({s.line[e], s.line[(e + 1) % n]});
    }
    feet.push_back(std::move(f));
  }
  return feet;
}

std::vector<int> structure_owners(const TerrainSpec& spec, const std::vector<Footprint>& feet, const Grid& bed,
                                  double dp) {
  std::vector<int> owner(bed.values.size(), -1);
  for (size_t k = 0; k < feet.size(); ++k) {
    const std::string& name = spec.structures[k].name;
    size_t count = 0, nodata = 0;
    for (int j = 0; j < bed.ny; ++j)
      for (int i = 0; i < bed.nx; ++i) {
        if (!feet[k].contains(bed.cx(i), bed.cy(j))) continue;
        const size_t c = column(bed, i, j);
        if (std::isnan(bed.values[c])) {
          ++nodata;
          continue;
        }
        if (owner[c] >= 0)
          throw TerrainError(structure_field(k), "'" + name + "' overlaps structures[" + std::to_string(owner[c]) +
                                                     "] ('" + spec.structures[owner[c]].name + "') at map " +
                                                     point(bed.cx(i), bed.cy(j)) + ": structures must not overlap");
        owner[c] = static_cast<int>(k);
        ++count;
      }
    if (nodata > 0)
      throw TerrainError(structure_field(k),
                         "'" + name + "' lies partly on DEM nodata (" + std::to_string(nodata) + " columns)");
    if (count == 0)
      throw TerrainError(structure_field(k), "'" + name + "' covers no dp x dp column at dp = " + num(dp) + " m");
  }
  return owner;
}

void regrade_and_excavate(TerrainModel& m, const TerrainSpec& spec, const std::vector<int>& owner) {
  Grid& bed = m.bed;
  const double cell = m.dp * m.dp;
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    StructureInfo info;
    info.name = s.name;
    info.kind = s.kind;
    info.outline = s.line;
    if (s.kind == StructureKind::deposition_area) {
      regrade_deposition_area(bed, owner, static_cast<int>(k), s, cell, info);
    } else if (s.kind == StructureKind::retention_basin) {
      for (int j = 0; j < bed.ny; ++j)
        for (int i = 0; i < bed.nx; ++i)
          if (owner[column(bed, i, j)] == static_cast<int>(k) && inside_polygon(s.line, bed.cx(i), bed.cy(j))) {
            bed.at(i, j) -= static_cast<float>(s.depth);
            info.cut_volume += s.depth * cell;
          }
    }
    m.structures.push_back(std::move(info));
  }
}

void build_walls(TerrainModel& m, const TerrainSpec& spec, const std::vector<Footprint>& feet,
                 const std::vector<int>& owner) {
  const Grid& bed = m.bed;
  m.wall_top = bed.like(Grid::nodata);
  m.wall_owner.assign(bed.values.size(), -1);
  uint32_t next_tag = 2;
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    if (s.kind == StructureKind::deposition_area) continue;
    if (s.kind == StructureKind::retention_basin && !(s.wall_height > 0)) continue;
    m.structures[k].tag = next_tag++;
    if (s.kind == StructureKind::check_dam) build_dam_wall(m, s, static_cast<int>(k), owner);
    else build_basin_walls(m, s, feet[k], static_cast<int>(k), owner);
  }
  const int nx = bed.nx;
  m.wall_interior.assign(bed.values.size(), 0);
  for (int j = 1; j + 1 < bed.ny; ++j)
    for (int i = 1; i + 1 < nx; ++i) {
      const size_t c = column(bed, i, j);
      m.wall_interior[c] = m.wall_owner[c] >= 0 && m.wall_owner[c - 1] >= 0 && m.wall_owner[c + 1] >= 0 &&
                           m.wall_owner[c - nx] >= 0 && m.wall_owner[c + nx] >= 0;
    }
}

void storage_capacities(TerrainModel& m, const TerrainSpec& spec, const std::vector<Footprint>& feet,
                        const std::vector<int>& owner) {
  for (size_t k = 0; k < spec.structures.size(); ++k) {
    const auto& s = spec.structures[k];
    if (s.kind == StructureKind::check_dam) dam_storage(m.bed, s, feet[k], owner, m.dp, m.structures[k]);
    else if (s.kind == StructureKind::retention_basin)
      basin_storage(m, s, feet[k], static_cast<int>(k), owner, m.structures[k]);
  }
}

}  // namespace runout::terrain::detail
