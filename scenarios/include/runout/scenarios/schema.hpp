#pragma once
// The scene format described from the models' own descriptors (engine/include/runout/engine/parameters.hpp):
// a JSON Schema for editors and the service, and the parameter tables of docs/scene-format.md.
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace runout {

// JSON Schema (2020-12) of a scene. Materials are described in full (one alternative per rheology, with each
// parameter's unit, default, range and doc); the other sections name their accepted keys' types only.
nlohmann::json scene_schema();

// The Markdown of docs/scene-format.md between its "material-parameters" markers: one table per rheology.
std::string material_parameter_tables();

}  // namespace runout
