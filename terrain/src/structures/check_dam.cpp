// Check dam: a wall along an axis, its crest `crest_height` over the lowest ground on the axis (the thalweg),
// with an optional slit; it stores what lies upstream of it below its crest.
#include <algorithm>
#include <cmath>

#include "runout/engine/geometry.hpp"
#include "structure_steps.hpp"

namespace runout::terrain::detail {
namespace {

FieldSpec slit_field() {
  FieldSpec f = shaped_field("slit", "object", "an opening centred on the axis's lowest ground point, open from `bottom` above it",
                             false);
  f.parameters = {{"width", "m", 0.0, 0.0, 1000.0, true, false, true, "slit width"},
                  {"bottom", "m", 0.0, 0.0, 200.0, false, false, false,
                   "height of the slit's sill above the lowest ground on the axis (below crest_height)"}};
  return f;
}

std::optional<StructureProblem> check(const StructureSpec& s) {
  if (s.has("slit.width") && s.number("slit.bottom") >= s.number("crest_height"))
    return StructureProblem{"slit.bottom", "must be below crest_height (" + message_number(s.number("crest_height")) + " m)"};
  return std::nullopt;
}

void footprint(const StructureSpec& s, const Grid&, double min_half_wall, Footprint& f) {
  f.half_wall = std::max(0.5 * s.number("thickness"), min_half_wall);
}

// The crest stands crest_height over the lowest ground on the axis (the thalweg), the slit (if any)
// slit.bottom over it.
void lay_walls(TerrainModel& m, const StructureSpec& s, const Footprint&, int k, const std::vector<int>& owner) {
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
      const double z = m.dem->sample(s.line[e][0] + t * ex, s.line[e][1] + t * ey);
      if (!std::isnan(z) && z < thalweg_z) thalweg_z = z, thalweg_s = s0 + t * len;
    }
    s0 += len;
  }
  const double crest = thalweg_z + s.number("crest_height");
  const double slit_width = s.number("slit.width");
  info.crest_elevation = crest;
  info.wall_height_built = s.number("crest_height");
  info.wall_thickness = s.number("thickness");
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i) {
      const size_t c = column(bed, i, j);
      if (owner[c] != k) continue;
      double along;
      distance_to_polyline(s.line, bed.cx(i), bed.cy(j), &along);
      double top = crest;
      if (slit_width > 0 && std::abs(along - thalweg_s) <= 0.5 * slit_width) top = thalweg_z + s.number("slit.bottom");
      raise_wall(m, c, k, top);
    }
}

// +1/-1 by the side of the axis a map point is on (of the segment nearest to it); a point exactly on the
// axis counts as -1.
double axis_side(const Polyline& line, double x, double y) {
  SegmentRules rules;
  rules.on_line_side = -1;
  return nearest_segment(line, x, y, rules).side;
}

// The upstream side: the side of the axis whose ground next to the dam is higher on average.
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

// Flood from the upstream face through columns below the crest, staying on the upstream side.
void storage(TerrainModel& m, const StructureSpec& s, const Footprint& f, int k, const std::vector<int>& owner) {
  const Grid& bed = m.bed;
  StructureInfo& info = m.structures[k];
  const int nx = bed.nx, ny = bed.ny;
  const double dp = m.dp, cell = dp * dp;
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
    if (f.near(x, y, 1.5 * dp) && distance_to_polyline(s.line, x, y) <= f.half_wall + 1.5 * dp &&
        axis_side(s.line, x, y) == up) {
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

// Held: upstream of the axis (within the axis' span) and below the crest; below_rim = false, at any height
// (the deposit wedge on a steep bed mostly stands above the crest). Upstream: behind the nearest segment of
// those whose extent the point is in, against the flow normal (the side by the flow, not by the segment's
// direction).
bool holds(const StructureInfo& st, double x, double y, double z, bool below_rim) {
  if (below_rim && z >= st.crest_elevation) return false;
  SegmentRules rules;
  rules.ends = SegmentRules::Ends::skip;
  const NearestSegment n = nearest_segment(st.outline, x, y, rules);
  if (n.index < 0) return false;
  const auto& a = st.outline[n.index];
  return (x - a[0]) * st.flow_normal[0] + (y - a[1]) * st.flow_normal[1] < 0;
}

const StructureSteps steps{footprint, nullptr, lay_walls, storage};

}  // namespace

const StructureType& check_dam_type() {
  static const StructureType type{
      "check_dam",
      "a wall along the axis, crest level at the lowest ground on the axis + crest_height",
      {geometry_field("axis", false, "the dam's axis: at least 2 [x, y] points (map coordinates, m)"),
       number_field({"crest_height", "m", 0.0, 0.0, 200.0, true, false, true, "crest above the lowest ground on the axis"}),
       number_field({"thickness", "m", 0.0, 0.0, 100.0, true, false, true, "wall thickness"}), slit_field()},
      false,
      "check dam",
      "#3b3b3b",
      check,
      holds,
      true,
      &steps};
  return type;
}

}  // namespace runout::terrain::detail
