// The keys of the terrain scene's sections (terrain, terrain.corridor, release, release.hydrograph,
// protected_zones[]) declared once: the readers (terrain.cpp, inlets.cpp), `runout schema` and
// docs/scene-format.md's generated tables read them.
#include "readers.hpp"

namespace runout::scene_reader {

const std::vector<std::string>& terrain_wall_choices() {
  static const std::vector<std::string> choices = {"near_flow", "all"};
  return choices;
}

const std::vector<FieldSpec>& terrain_fields() {
  static const std::vector<FieldSpec> fields = [] {
    FieldSpec walls = shaped_field(
        "walls", "string",
        "`near_flow`: the bed's particles are laid during the run only within reach of the flow (column by column, "
        "within 2h + cfl·h + dp/2 of a flow particle) and dropped behind it, so memory and work follow the wetted "
        "footprint; `all`: the whole corridor's bed from the start (the same results to the bit on one thread)",
        false);
    walls.default_text = "near_flow";
    FieldSpec crs = shaped_field("crs", "string",
                                 "working CRS, anything OGRSpatialReference::SetFromUserInput takes (EPSG:32616); "
                                 "none keeps a projected DEM's CRS and sends a geographic one to the UTM zone of its "
                                 "centre",
                                 false);
    return std::vector<FieldSpec>{
        shaped_field("dem", "string",
                     "a single-band raster GDAL opens, with a CRS (nodata honoured), relative to the scene file"),
        crs,
        number_field({"resolution", "m", 0.0, 0.0, 1e4, false, false, false,
                      "cell size after reprojection; 0 keeps about the native one"}),
        number_field({"layers", "", 3.0, 2.0, 10.0, false, false, false,
                      "boundary particle layers under the ground (each column reaches its lowest neighbour's surface "
                      "minus the layers, so the sheet has no holes)",
                      true}),
        walls,
        shaped_field("corridor", "object", "the part of the DEM the flow can reach (terrain.corridor, below)", false)};
  }();
  return fields;
}

const std::vector<FieldSpec>& corridor_fields() {
  static const std::vector<FieldSpec> fields = {
      number_field({"travel_angle", "deg", 11.0, 0.0, 60.0, true, false, false,
                    "energy-line reach: a cell is modelled when some path from the release keeps the line falling at "
                    "this angle from the release surface above the ground"}),
      number_field({"buffer", "m", 0.0, 0.0, 1e5, false, false, false, "widening of the reach"}, 0,
                   "max(20 m, 10 dp)"),
      shaped_field("polygon", "polyline", "the corridor itself, instead of the reach (several parts and holes allowed)",
                   false, 0, 3),
      number_field({"max_outflow", "", 0.01, 0.0, 1.0, false, false, false,
                    "the share of the released mass (a hydrograph's inflow so far included) that may leave past the "
                    "corridor's edge inside the DEM before the run fails"})};
  return fields;
}

const std::vector<FieldSpec>& release_fields() {
  static const std::vector<FieldSpec> fields = [] {
    FieldSpec polygon = shaped_field(
        "polygon", "polyline",
        "where the flow starts, inside the DEM with no nodata under it (a layer may hold several parts and holes); "
        "required unless hydrograph",
        false, 0, 3);
    return std::vector<FieldSpec>{
        polygon,
        number_field({"depth", "m", 0.0, 0.0, 1000.0, true, false, false,
                      "flow depth on the ground, rounded to whole dp layers; one of depth and volume with a polygon"},
                     0, "none"),
        number_field({"volume", "m3", 0.0, 0.0, 1e9, true, false, false,
                      "flow volume over the polygon (the volume placed is reported); one of depth and volume"},
                     0, "none"),
        shaped_field("material", "string", "the flow's material: a name from materials"),
        shaped_field("hydrograph", "object",
                     "instead of polygon: the flow arrives through a cross-section over time (release.hydrograph, "
                     "below)",
                     false)};
  }();
  return fields;
}

const std::vector<FieldSpec>& hydrograph_fields() {
  static const std::vector<FieldSpec> fields = [] {
    FieldSpec discharge = shaped_field(
        "discharge", "series",
        "Q(t) in m3/s: a number, or [[t, Q], ...] with t increasing, linear between points and held after the last; "
        "or else volume with duration",
        false);
    discharge.parameters = {{"discharge", "m3/s", 0.0, 0.0, 1e6, false, false, false, "a discharge"}};
    return std::vector<FieldSpec>{
        shaped_field("line", "polyline",
                     "the inflow section across the channel: a straight line of two points inside the DEM, at least "
                     "dp long",
                     true, 0, 2),
        number_field({"depth", "m", 0.0, 0.0, 1000.0, true, false, true,
                      "the inflow's depth above the bed (whole layers of dp, at least one)"}),
        discharge,
        number_field({"volume", "m3", 0.0, 0.0, 1e9, true, false, false,
                      "a surge: Q = 2 V / T at t = 0, falling linearly to 0 at T = duration"},
                     0, "none"),
        number_field({"duration", "s", 0.0, 0.0, 1e6, true, false, false, "the surge's duration T, with volume"}, 0,
                     "none")};
  }();
  return fields;
}

const std::vector<FieldSpec>& protected_zone_fields() {
  static const std::vector<FieldSpec> fields = {
      shaped_field("name", "string", "the zone's name, as metrics report it"),
      shaped_field("polygon", "polyline", "the zone: a village, a road (a layer may hold several parts and holes)",
                   true, 0, 3)};
  return fields;
}

std::set<std::string> field_keys(const std::vector<FieldSpec>& fields) {
  std::set<std::string> keys;
  for (const auto& f : fields) keys.insert(f.key);
  return keys;
}

}  // namespace runout::scene_reader
