#pragma once
// A terrain scene: the reachable corridor of a DEM as boundary particles, the structures a layout places on
// it, and the release filled with flow particles. Coordinates: structures, release and zones are given in
// map coordinates of the working (projected) CRS; the particles live in a local frame
// x = map_x - origin_x, y = map_y - origin_y, z = elevation, so positions keep their precision in the solver
// (snapshots add the origin back, in Float64).
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "runout/engine/parameters.hpp"
#include "runout/engine/state_io.hpp"
#include "runout/engine/types.hpp"
#include "runout/engine/wall_source.hpp"
#include "runout/terrain/raster.hpp"

namespace runout::terrain {

using MapPoint = std::array<double, 2>;
using Polyline = std::vector<MapPoint>;  // a polygon is a polyline read as closed (last joins first)

double polygon_area(const Polyline& polygon);
bool inside_polygon(const Polyline& polygon, double x, double y);
// Distance to a polyline, and the arc length along it of the closest point.
double distance_to_polyline(const Polyline& line, double x, double y, double* along = nullptr);

struct CorridorSpec {
  // Energy-line reach: a cell is reachable when a path from the release exists along which the line
  // falling at the travel angle from the release surface stays above the ground.
  double travel_angle_deg = 11.0;
  double buffer_m = 0.0;  // widening of the reach; 0 = max(20 m, 10 dp)
  Polyline polygon;       // if given, the corridor is this polygon (the reach is not computed)
  // Flow that crosses the corridor's edge is removed as outflow (the model ends there); the run fails when
  // more than this fraction of the released mass has left that way: the corridor is then too narrow.
  double max_outflow = 0.01;
};

struct ReleaseSpec {
  Polyline polygon;
  double depth = 0.0;   // one of depth or volume is > 0
  double volume = 0.0;
  // A hydrograph release instead of a block: flow enters `depth` deep across this straight line (two points)
  // from its uphill side, and no particles are placed. build_terrain then takes as the polygon the strip of
  // `inflow_length` behind the line (where the inlet's buffer runs), which seeds the corridor's reach.
  Polyline inflow_line;
  double inflow_length = 0.0;
};

struct StructureType;

// One structure as a scene places it: its type, its geometry and the numbers its type declares.
struct StructureSpec {
  const StructureType* type = nullptr;
  std::string name;
  Polyline line;  // the type's geometry: an axis (a line) or a polygon
  // The type's numbers by key, an object's members as "object.member" ("slit.width"); a number whose default
  // the type computes (a deposition area's elevation) is absent when the scene leaves it out.
  ParameterValues numbers;
  std::map<std::string, std::vector<int>> indices;  // its "indices" fields as given (a basin's open_edges)
  double number(const std::string& key) const;  // 0 when absent
  bool has(const std::string& key) const { return numbers.count(key) > 0; }
};
struct StructureInfo;
namespace detail {
struct StructureSteps;  // what a type does on the bed grid (terrain/src/structures/), private to this library
}

// A rule across a structure's keys that their ranges cannot say, broken: the key at fault, relative to the
// structure ("slit.bottom"; "" for the structure as a whole), and why.
struct StructureProblem {
  std::string key;
  std::string message;
};

// A structure type: its name, one line of doc and its keys (geometry and numbers, each declared once; read by
// the scene parser, `runout schema` and docs/scene-format.md), and its behaviour. One file per type under
// terrain/src/structures/, listed once in structure_types() (structure_types.cpp).
struct StructureType {
  std::string name;
  std::string doc;
  std::vector<FieldSpec> fields;  // besides "type" and "name"; the first "polyline" field is its geometry
  bool area = false;              // its geometry is a polygon (false: an axis, drawn and laid as a line)
  std::string label;              // in words, for map legends
  std::string colour;             // "#rrggbb" of its map style (areas)
  // The first rule across its keys that `s` breaks, or nothing.
  std::optional<StructureProblem> (*check)(const StructureSpec& s) = nullptr;
  // Whether flow at map (x, y) and elevation z counts as held by the structure at the end of a run.
  // below_rim = false: what it held back at any height (a check dam's upstream wedge, reported besides).
  bool (*holds)(const StructureInfo& st, double x, double y, double z, bool below_rim) = nullptr;
  bool reports_upstream = false;  // metrics give its held flow at any height too (upstream_volume_m3)
  const detail::StructureSteps* steps = nullptr;
};
const std::vector<const StructureType*>& structure_types();
// Throws std::invalid_argument for an unknown name.
const StructureType& structure_type(const std::string& name);

struct ProtectedZone {
  std::string name;
  Polyline polygon;
};

struct TerrainSpec {
  std::string dem_path;
  DemOptions dem;
  int layers = 3;  // boundary particle layers under the surface
  CorridorSpec corridor;
  ReleaseSpec release;
  std::vector<StructureSpec> structures;
  std::vector<ProtectedZone> protected_zones;
};

struct StructureInfo {
  std::string name;
  const StructureType* type = nullptr;
  uint32_t tag = 0;           // boundary tag of its wall particles (0 if it has no wall)
  Polyline outline;           // map coordinates: the axis (dam) or the polygon
  double cut_volume = 0.0;    // [m3] ground removed (regrading, excavation)
  double fill_volume = 0.0;   // [m3] ground added by regrading
  double crest_elevation = 0.0;  // dam crest / basin wall top (lowest), [m]
  double storage_capacity = 0.0; // [m3] volume the structure holds up to its crest/rim, from the bed grid
  double wall_height_built = 0.0; // [m] wall particles' crest above the local bed at its lowest point
  double wall_thickness = 0.0;    // [m] as the scene gives it (0: no wall)
  // Horizontal unit vector the flow pushes the structure along (map axes): a dam's downstream normal, a
  // basin's mean downhill direction. Zero for a deposition area.
  std::array<double, 2> flow_normal{0.0, 0.0};
};

// The structures as built, added as layers to an existing GeoPackage (the run's hazard.gpkg; terrain/src/
// polygonize.cpp), in the CRS `crs_wkt` (under its EPSG code where identified), so a map shows what was
// simulated: `check_dams` (the axes as lines) and `structure_areas` (deposition areas and retention basins as
// polygons), each feature with its name, type, crest elevation, built wall height, storage capacity, cut and
// fill volumes, and the flow it held at the end (retained[k], upstream[k] for a check dam; NaN: not known). A
// layer with no structure is not written.
void write_structure_layers(const std::string& gpkg_path, const std::vector<StructureInfo>& structures,
                            const std::string& crs_wkt, const std::vector<double>& retained,
                            const std::vector<double>& upstream);

// A built terrain scene. All particle positions are local (see the header comment).
struct TerrainModel {
  std::shared_ptr<const Grid> dem;  // working DEM, projected, as loaded (shared with load_dem's keep)
  Grid bed;       // bed elevation at dp spacing over the corridor's bounding box after structures; NaN off it
  Grid original;  // the same before structures
  double origin_x = 0.0, origin_y = 0.0;
  double dp = 0.0;
  double modelled_fraction = 0.0;  // corridor area / area of the DEM with data
  double corridor_area = 0.0;      // [m2]
  double max_corridor_outflow = 0.01;  // CorridorSpec::max_outflow
  std::vector<StructureInfo> structures;
  std::vector<ProtectedZone> protected_zones;
  Polyline release_polygon;
  double release_volume = 0.0;     // [m3] of the particles placed
  // A hydrograph release: its line (map coordinates) and the horizontal unit vector it lets the flow in
  // along (map axes, downhill); empty line for a block release.
  Polyline inflow_line;
  std::array<double, 2> inflow_normal{0.0, 0.0};
  double release_depth = 0.0;      // [m]
  // Largest height of the energy line above the ground over the reach (at least the release depth): the
  // sliding-block speed scale sqrt(2 g E) the default speed of sound is built on.
  double max_energy_height = 0.0;
  // Particles. The bed's are laid near the flow during the run (bed_wall_source); per bed column, how many
  // it has under its surface (0 off the corridor). The structures' wall particles always exist.
  std::vector<uint16_t> bed_layers;
  std::vector<Vec<3>> boundary;
  std::vector<uint32_t> boundary_tag;  // one per walled structure (StructureInfo::tag; 1 is the bed's)
  std::vector<Vec<3>> fluid;
  std::vector<real> fluid_depth;       // below the release surface, for the hydrostatic start
  // Domain faces that lie on the DEM's edge (flow may leave there): [axis][low/high].
  std::array<std::array<bool, 2>, 2> open_faces{};

  // Walls at dp spacing on the bed grid: top elevation (NaN where there is no wall), owner index into
  // `structures`, and whether the column is inside the wall (all four neighbours are wall too).
  Grid wall_top;
  std::vector<int> wall_owner;
  std::vector<char> wall_interior;

  // Bed elevation at a local point (bilinear on `bed`), NaN off the corridor.
  double bed_at(double x, double y) const;
  // Why a fluid particle at local p is where no particle may be (under the ground, inside a wall, off the
  // corridor), or "" if it is fine.
  std::string misplaced(const Vec<3>& p) const;
  // Whether local p is off the corridor, where the flow leaves the model: over a column outside it, or past
  // a face of its box that is not on the DEM's edge (flow through those is the engine's outflow).
  bool off_corridor(const Vec<3>& p) const;
};

// The bed's particles as a wall source (runout/engine/wall_source.hpp): column (i, j) has bed_layers particles
// at bed - (k + 1/2) dp, tag 1, cut in depth into tiles of kBedSlabLayers layers (top down).
constexpr int kBedSlabLayers = 1;
std::shared_ptr<const WallSource<3>> bed_wall_source(std::shared_ptr<const TerrainModel> model);

// Throws TerrainError naming the field at fault (terrain.dem, release.polygon, structures[k], dp) for bad
// input, before any particle is made; `max_particles` bounds the particle count.
TerrainModel build_terrain(const TerrainSpec& spec, double dp, long max_particles = 5'000'000);

// build_terrain keeps the corridor's energy-line reach (with its buffer) of the last few (DEM, release,
// corridor, dp) it was given: what that keep has answered in this process, and how many it holds.
struct KeptReachStats {
  long hits = 0, misses = 0;
  size_t kept = 0;
};
KeptReachStats kept_reach_stats();

// Inundation on the DEM's raster (a window of it around the corridor, aligned with its cells): running
// max depth and max speed, and the depth at the last update. Depth in a cell is the flow volume over it
// divided by its area (each particle's volume spread over the dp x dp square around it).
class InundationGrid {
 public:
  InundationGrid() = default;
  explicit InundationGrid(const TerrainModel& model);
  // positions local; volume = m / rho; speed = |v|
  // `time` and `threshold` record each cell's first arrival: the first update at which its depth reaches
  // the threshold. `densities` (kg/m3 per particle, the material's bulk density) enable max_pressure.
  void update(const std::vector<Vec<3>>& positions, const std::vector<real>& volumes,
              const std::vector<real>& speeds, double time = 0.0, double threshold = 0.0,
              const std::vector<real>& densities = {});
  const Grid& max_depth() const { return max_depth_; }
  const Grid& max_speed() const { return max_speed_; }
  // Running max of h v [m2/s]: per update, the depth times the cell's volume-weighted mean speed, i.e.
  // (1 / cell area) * sum over the particles' shares on the cell of share volume * |v|.
  const Grid& max_hv() const { return max_hv_; }
  // Running max of the hydrodynamic impact pressure rho v^2 [Pa]: per update, the volume-weighted mean of
  // rho |v|^2 over the particles' shares on the cell, where the depth reaches the threshold (0 elsewhere;
  // all 0 without densities). docs/terrain.md says why this pressure.
  const Grid& max_pressure() const { return max_pressure_; }
  const Grid& depth() const { return depth_; }
  const Grid& terrain() const { return terrain_; }
  const Grid& arrival_time() const { return arrival_; }  // [s]; NaN where the flow never reached the threshold
  // Cells with max depth >= threshold, times the cell area.
  double inundated_area(double threshold) const;
  // The running maxima, the arrival times and the last update's sums, for a run's checkpoint: load_state on a
  // grid built from the same terrain continues as the saved one would have.
  void save_state(StateWriter& out) const;
  void load_state(StateReader& in);

 private:
  double origin_x_ = 0, origin_y_ = 0, dp_ = 0;
  Grid terrain_, max_depth_, max_speed_, depth_, arrival_, max_hv_, max_pressure_;
  // Per update and cell, sums over the particles' shares on it: volume, volume * |v|, volume * rho |v|^2.
  std::vector<double> vol_, hv_, rho_v2_;
  std::vector<size_t> touched_;     // the cells the last update reached
  std::vector<char> touched_flag_;  // per cell: in touched_
};

}  // namespace runout::terrain
