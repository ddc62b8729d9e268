#pragma once
// The wall models: how boundary particles get their pressure and how they act on the fluid next to them.
// One line per model (its policy is engine/src/wall/<id>.hpp); the enum, the names, the docs and the solver's
// dispatch are generated from this list, so a model cannot be parsed without being dispatched.
#include <string>
#include <vector>

namespace runout {

// X(id, doc): the scene names the model by its id.
#define RUNOUT_WALL_MODELS(X)                                                                                   \
  X(dbc, "dynamic boundary: wall particles carry a density by the continuity equation (Crespo et al. 2007)") \
  X(extrapolated,                                                                                              \
    "wall pressure extrapolated each step from the fluid next to it, with the hydrostatic term (Adami, Hu & " \
    "Adams 2012): no memory, so no pressure cushion under a thinning layer")

enum class BoundaryPressure {
#define RUNOUT_WALL_MODEL_ENUM(id, doc) id,
  RUNOUT_WALL_MODELS(RUNOUT_WALL_MODEL_ENUM)
#undef RUNOUT_WALL_MODEL_ENUM
};

// In the enum's order.
const std::vector<std::string>& boundary_pressure_names();
const std::vector<std::string>& boundary_pressure_docs();
// Throws std::invalid_argument naming the accepted values.
BoundaryPressure boundary_pressure_from_name(const std::string& name);

}  // namespace runout
