// The structure types' descriptors: what a scene writes for each kind (docs/scene-format.md, "structures").
// The geometry they make is built in structures.cpp; the scene parser reads these keys, ranges and docs.
#include <stdexcept>

#include "runout/terrain/terrain.hpp"

namespace runout::terrain {
namespace {

FieldSpec polyline_field(const std::string& key, size_t min_points, const std::string& doc) {
  return shaped_field(key, "polyline", doc, true, 0, min_points);
}

FieldSpec slit_field() {
  FieldSpec f = shaped_field("slit", "object", "an opening centred on the axis's lowest ground point, open from `bottom` above it",
                             false);
  f.parameters = {{"width", "m", 0.0, 0.0, 1000.0, true, false, true, "slit width"},
                  {"bottom", "m", 0.0, 0.0, 200.0, false, false, false,
                   "height of the slit's sill above the lowest ground on the axis (below crest_height)"}};
  return f;
}

FieldSpec open_edges_field() {
  return shaped_field("open_edges", "indices",
                      "edges without a wall (edge k joins vertex k to k + 1); default: the edge whose midpoint is highest",
                      false);
}

const StructureType check_dam_type{
    StructureKind::check_dam,
    "check_dam",
    "a wall along the axis, crest level at the lowest ground on the axis + crest_height",
    {polyline_field("axis", 2, "the dam's axis: at least 2 [x, y] points (map coordinates, m)"),
     number_field({"crest_height", "m", 0.0, 0.0, 200.0, true, false, true, "crest above the lowest ground on the axis"}),
     number_field({"thickness", "m", 0.0, 0.0, 100.0, true, false, true, "wall thickness"}), slit_field()}};

const StructureType deposition_area_type{
    StructureKind::deposition_area,
    "deposition_area",
    "the bed inside becomes a plane through the centroid falling along the ground's mean downhill direction",
    {polyline_field("polygon", 3, "the area: at least 3 [x, y] points (map coordinates, m)"),
     number_field({"elevation", "m", 0.0, -500.0, 9000.0, false, false, false, "the plane's elevation at the centroid"},
                  0, "the mean ground elevation inside"),
     number_field({"gradient", "m/m", 0.0, 0.0, 1.0, false, false, false, "the plane's downhill slope"})}};

const StructureType retention_basin_type{
    StructureKind::retention_basin,
    "retention_basin",
    "bed lowered by depth inside, a wall on every edge except the open ones (depth > 0 or wall_height > 0)",
    {polyline_field("polygon", 3, "the basin: at least 3 [x, y] points (map coordinates, m)"),
     number_field({"depth", "m", 0.0, 0.0, 100.0, false, false, false, "how far the bed inside is lowered"}),
     number_field({"wall_height", "m", 0.0, 0.0, 100.0, false, false, false, "wall height on the closed edges"}),
     number_field({"wall_thickness", "m", 0.0, 0.0, 100.0, true, false, false, "wall thickness"}, 0,
                  "required with a wall (wall_height > 0)"),
     open_edges_field()}};

}  // namespace

// The registration list: one line per structure type, in the order scenes and docs list them.
const std::vector<const StructureType*>& structure_types() {
  static const std::vector<const StructureType*> types = {
      &check_dam_type,
      &deposition_area_type,
      &retention_basin_type,
  };
  return types;
}

const StructureType& structure_type(const std::string& name) {
  return find_model(structure_types(), name, "structure type");
}

}  // namespace runout::terrain
