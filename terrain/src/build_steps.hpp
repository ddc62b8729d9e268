#pragma once
// The steps of build_terrain (build.cpp), in its order: the corridor on the DEM and the bed grid at dp over
// it (corridor.cpp), the structures' footprints, regrading, walls and storage (structures.cpp), and the
// boundary and release particles (particles.cpp). Private to the terrain library.
#include <array>
#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "runout/terrain/terrain.hpp"

namespace runout::terrain::detail {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Numbers and map points for messages, at 10 significant digits.
std::string num(double v);
std::string point(double x, double y);
std::string structure_field(size_t k);

// Where a structure stands on the map (walls widened to at least `layers` particle columns).
struct Footprint {
  const StructureSpec* s;
  double half_wall;
  std::vector<Polyline> walled_edges;  // basins
  bool contains(double x, double y) const;
  // Whether (x, y) is in the bounding box of the structure's line widened by half_wall + extra: a point
  // outside it is farther than that from the line, so whole-grid scans skip it before any distance.
  bool near(double x, double y, double extra) const {
    const double r = half_wall + extra + 1e-6;  // a micrometre over: the distances' rounding never decides
    return x >= box[0] - r && x <= box[1] + r && y >= box[2] - r && y <= box[3] + r;
  }
  std::array<double, 4> box{};  // the line's x0, x1, y0, y1 (footprints sets it)
  double reach() const { return half_wall; }
  bool walled(const Polyline& edge) const;  // a basin edge that carries a wall
};
std::vector<Footprint> footprints(const TerrainSpec& spec, const Grid& dem, double dp);

// The corridor's bounding box in DEM cells, and how many cells it keeps of those with data.
struct CorridorBox {
  int i0, i1, j0, j1;
  size_t valid = 0, kept = 0;
};
// Drops nodata cells from the corridor; throws if none is left.
CorridorBox corridor_box(const Grid& dem, std::vector<char>& corridor);

// DEM cells the model covers (nodata dropped) and their box: the energy-line reach (buffered) or the corridor
// polygon, plus every structure's footprint. Sets max_energy_height (at least the release depth). The reach,
// its buffer and its box are kept for the last few (DEM, release, corridor, dp) this process built
// (kept_reach_stats); when no footprint adds a cell to it, `cells` is the kept reach itself, not a copy.
struct Corridor {
  std::shared_ptr<const std::vector<char>> cells;
  CorridorBox box;
};
Corridor corridor_cells(const TerrainSpec& spec, const std::shared_ptr<const Grid>& dem,
                        const std::vector<Footprint>& feet, double release_depth, double dp,
                        double& max_energy_height);

// m.original and m.bed at m.dp over the box, the local origin and the open faces.
void lay_bed(TerrainModel& m, const std::vector<char>& corridor, const CorridorBox& box, int layers,
             long max_particles);

// Bed columns under the release polygon; throws if any has no ground or there are none.
std::vector<size_t> release_columns(const Polyline& polygon, const Grid& bed, double dp);

// Structure index owning each bed column (-1: none); throws for overlaps, nodata and empty footprints.
std::vector<int> structure_owners(const TerrainSpec& spec, const std::vector<Footprint>& feet, const Grid& bed,
                                  double dp);

// m.structures, with the bed regraded (deposition areas) and excavated (basins).
void regrade_and_excavate(TerrainModel& m, const TerrainSpec& spec, const std::vector<int>& owner);
// m.wall_top, m.wall_owner, m.wall_interior and the structures' wall tags, crests and built heights.
void build_walls(TerrainModel& m, const TerrainSpec& spec, const std::vector<Footprint>& feet,
                 const std::vector<int>& owner);
// The structures' storage capacities and flow normals.
void storage_capacities(TerrainModel& m, const TerrainSpec& spec, const std::vector<Footprint>& feet,
                        const std::vector<int>& owner);

// Wall particles column c carries from its bed up to its wall top (0 without a wall): whole layers, so their
// top surface, bed + count dp, may stand up to dp/2 off wall_top (a dam's crest is one level along its axis).
int wall_count(const TerrainModel& m, size_t c);

// m.bed_layers: `layers` under each column and more on steep ground; m.boundary: the wall particles on top.
// Throws when the walls and the release would pass max_particles.
void lay_boundary_particles(TerrainModel& m, int layers, size_t release_columns, double release_depth,
                            long max_particles);
// m.fluid: the release columns filled to its depth (or volume); throws if one is in a wall.
void fill_release(TerrainModel& m, const ReleaseSpec& release, const std::vector<size_t>& columns);

}  // namespace runout::terrain::detail
