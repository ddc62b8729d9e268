#pragma once
// The scene format described from the models' own descriptors (engine/include/runout/engine/parameters.hpp):
// a JSON Schema for editors and the service, and the parameter tables of docs/scene-format.md.
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace runout {

// JSON Schema (2020-12) of a scene. Materials, boundaries, monitors and structures are described in full (one
// alternative per rheology, boundary type, monitor type and structure type, with each key's unit, default, range and doc), and the
// numerics' keys; the other sections name their accepted keys' types only.
nlohmann::json scene_schema();

// The Markdown of docs/scene-format.md between its "material-parameters" markers: one table per rheology.
std::string material_parameter_tables();
// Between its "monitor-types" and "structure-types" markers: one table per monitor type and structure type.
std::string monitor_type_tables();
std::string structure_type_tables();
// Between its "boundary-types" markers: the keys every boundary has, and one table per boundary type.
std::string boundary_type_tables();
// Between its "output-fields" markers: the output section's keys, output.intensity's members among them.
std::string output_field_table();
// The terrain scene's sections (terrain, terrain.corridor, release, release.hydrograph, protected_zones): one
// table each.
std::string terrain_field_tables();

}  // namespace runout
