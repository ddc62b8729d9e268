#pragma once
// What a structure type does on the bed grid, called by build_terrain's structure steps (structures.cpp) in
// their order, and the pieces the types share. Each type is one file in this folder; structure_types.cpp
// lists them. Private to the terrain library.
#include <string>
#include <vector>

#include "../build_steps.hpp"

namespace runout::terrain::detail {

struct StructureSteps {
  // Its walls' half thickness (at least min_half_wall; 0: no wall) and the polygon edges that carry them.
  void (*footprint)(const StructureSpec& s, const Grid& dem, double min_half_wall, Footprint& f) = nullptr;
  // Regrades or excavates the bed in its columns (owner == k), adding to info's cut and fill. Null: leaves it.
  void (*edit_bed)(Grid& bed, const std::vector<int>& owner, int k, const StructureSpec& s, double cell,
                   StructureInfo& info) = nullptr;
  // Raises its walls on its columns (raise_wall) and sets m.structures[k]'s crest, built height and wall
  // thickness; called where the footprint has a wall.
  void (*lay_walls)(TerrainModel& m, const StructureSpec& s, const Footprint& f, int k,
                    const std::vector<int>& owner) = nullptr;
  // m.structures[k]'s storage capacity and flow normal, on the finished bed and walls. Null: none.
  void (*storage)(TerrainModel& m, const StructureSpec& s, const Footprint& f, int k,
                  const std::vector<int>& owner) = nullptr;
};

inline size_t column(const Grid& bed, int i, int j) { return static_cast<size_t>(j) * bed.nx + i; }
// Raises the wall on column c to `top` where that is more than half a spacing above the bed.
void raise_wall(TerrainModel& m, size_t c, int k, double top);
// A structure's geometry as a field: a polygon (area) of at least 3 points or an axis of at least 2.
FieldSpec geometry_field(const std::string& key, bool area, const std::string& doc);
// A number as the scene's messages print it.
std::string message_number(double v);

// The types, one per file in this folder.
const StructureType& check_dam_type();
const StructureType& deposition_area_type();
const StructureType& retention_basin_type();

}  // namespace runout::terrain::detail
