// Retention basin: the bed inside lowered by `depth`, a wall of `wall_height` on every edge but the open ones
// (default: the edge whose midpoint is highest, where the flow comes in); it holds what lies inside below its
// overflow level.
#include <algorithm>
#include <cmath>

#include "structure_steps.hpp"

namespace runout::terrain::detail {
namespace {

FieldSpec open_edges_field() {
  return shaped_field("open_edges", "indices",
                      "edges without a wall (edge k joins vertex k to k + 1); default: the edge whose midpoint is highest",
                      false);
}

std::optional<StructureProblem> check(const StructureSpec& s) {
  if (!(s.number("depth") > 0) && !(s.number("wall_height") > 0))
    return StructureProblem{"", "a retention basin needs depth > 0 m or wall_height > 0 m (or both)"};
  if (s.number("wall_height") > 0 && !s.has("wall_thickness"))
    return StructureProblem{"wall_thickness", "missing (required with wall_height > 0: a number in (0, 100])"};
  return std::nullopt;
}

// The open edges: as given, or the edge whose midpoint is highest.
std::vector<int> open_edges(const StructureSpec& s, const Grid& dem) {
  const auto given = s.indices.find("open_edges");
  if (given != s.indices.end()) return given->second;
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

void footprint(const StructureSpec& s, const Grid& dem, double min_half_wall, Footprint& f) {
  if (!(s.number("wall_height") > 0)) return;
  f.half_wall = std::max(0.5 * s.number("wall_thickness"), min_half_wall);
  const size_t n = s.line.size();
  const std::vector<int> open = open_edges(s, dem);
  for (size_t e = 0; e < n; ++e)
    if (std::find(open.begin(), open.end(), static_cast<int>(e)) == open.end())
      f.walled_edges.push_back({s.line[e], s.line[(e + 1) % n]});
}

void edit_bed(Grid& bed, const std::vector<int>& owner, int k, const StructureSpec& s, double cell, StructureInfo& info) {
  const double depth = s.number("depth");
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i)
      if (owner[column(bed, i, j)] == k && inside_polygon(s.line, bed.cx(i), bed.cy(j))) {
        bed.at(i, j) -= static_cast<float>(depth);
        info.cut_volume += depth * cell;
      }
}

// The crest is level across the wall's thickness: the ground on its axis (the nearest walled edge) plus the
// wall height. The basin's crest elevation is the lowest wall top.
void lay_walls(TerrainModel& m, const StructureSpec& s, const Footprint& f, int k, const std::vector<int>& owner) {
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
      double ground = m.dem->sample(a[0] + t * (bpt[0] - a[0]), a[1] + t * (bpt[1] - a[1]));
      if (std::isnan(ground)) ground = m.original.at(i, j);
      const double top = ground + s.number("wall_height");
      lowest_top = std::min(lowest_top, top);
      raise_wall(m, c, k, top);
    }
  m.structures[k].crest_elevation = lowest_top;
  m.structures[k].wall_height_built = s.number("wall_height");
  m.structures[k].wall_thickness = s.number("wall_thickness");
}

// What it holds below its overflow level, the lowest of the wall tops and of the ground along the open
// edges; the flow enters over the open edges and pushes the walls away from them.
void storage(TerrainModel& m, const StructureSpec& s, const Footprint& f, int k, const std::vector<int>& owner) {
  const Grid& bed = m.bed;
  StructureInfo& info = m.structures[k];
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
  for (size_t c = 0; c < bed.values.size(); ++c)
    if (owner[c] == k && m.wall_owner[c] < 0 &&
        inside_polygon(s.line, bed.cx(static_cast<int>(c % bed.nx)), bed.cy(static_cast<int>(c / bed.nx))))
      info.storage_capacity += std::max(0.0, level - bed.values[c]) * cell;
}

bool holds(const StructureInfo& st, double x, double y, double z, bool) {
  return z < st.crest_elevation && inside_polygon(st.outline, x, y);
}

const StructureSteps steps{footprint, edit_bed, lay_walls, storage};

}  // namespace

const StructureType& retention_basin_type() {
  static const StructureType type{
      "retention_basin",
      "bed lowered by depth inside, a wall on every edge except the open ones (depth > 0 or wall_height > 0)",
      {geometry_field("polygon", true, "the basin: at least 3 [x, y] points (map coordinates, m)"),
       number_field({"depth", "m", 0.0, 0.0, 100.0, false, false, false, "how far the bed inside is lowered"}),
       number_field({"wall_height", "m", 0.0, 0.0, 100.0, false, false, false, "wall height on the closed edges"}),
       number_field({"wall_thickness", "m", 0.0, 0.0, 100.0, true, false, false, "wall thickness"}, 0,
                    "required with a wall (wall_height > 0)"),
       open_edges_field()},
      true,
      "retention basin",
      "#31688c",
      check,
      holds,
      false,
      &steps};
  return type;
}

}  // namespace runout::terrain::detail
