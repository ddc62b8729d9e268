// Structures on the bed grid, whatever their type: footprints, the columns they own, and their types' steps
// (terrain/src/structures/) on them in order: the bed's edits, the walls, the storage.
#include <algorithm>
#include <cmath>

#include "structures/structure_steps.hpp"

namespace runout::terrain::detail {

void raise_wall(TerrainModel& m, size_t c, int k, double top) {
  if (top > m.bed.values[c] + 0.5 * m.dp) {
    m.wall_top.values[c] = static_cast<float>(top);
    m.wall_owner[c] = k;
  }
}

bool Footprint::contains(double x, double y) const {
  if (!near(x, y, 0.0)) return false;
  if (!s->type->area) return distance_to_polyline(s->line, x, y) <= half_wall;
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
    f.box = {1e300, -1e300, 1e300, -1e300};
    for (const auto& p : s.line)
      f.box = {std::min(f.box[0], p[0]), std::max(f.box[1], p[0]), std::min(f.box[2], p[1]), std::max(f.box[3], p[1])};
    s.type->steps->footprint(s, dem, min_half_wall, f);
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
    info.type = s.type;
    info.outline = s.line;
    if (s.type->steps->edit_bed) s.type->steps->edit_bed(bed, owner, static_cast<int>(k), s, cell, info);
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
    if (!(feet[k].half_wall > 0)) continue;  // no wall
    m.structures[k].tag = next_tag++;
    s.type->steps->lay_walls(m, s, feet[k], static_cast<int>(k), owner);
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
    if (s.type->steps->storage) s.type->steps->storage(m, s, feet[k], static_cast<int>(k), owner);
  }
}

}  // namespace runout::terrain::detail
