#pragma once
// The wall models' dispatch, generated from RUNOUT_WALL_MODELS (runout/engine/wall_models.hpp): each id names
// its policy struct wall::<id> (this folder, one file each).
#include <stdexcept>

#include "dbc.hpp"
#include "extrapolated.hpp"
#include "runout/engine/wall_models.hpp"

namespace runout {
namespace wall {

// Calls f(policy) with the policy type of `kind`: once per evaluation, never per pair.
template <class F>
decltype(auto) with_wall_model(BoundaryPressure kind, F&& f) {
  switch (kind) {
#define RUNOUT_WALL_MODEL_CASE(id, doc) \
  case BoundaryPressure::id:            \
    return f(id{});
    RUNOUT_WALL_MODELS(RUNOUT_WALL_MODEL_CASE)
#undef RUNOUT_WALL_MODEL_CASE
  }
  throw std::invalid_argument("with_wall_model: not a registered wall model");
}

}  // namespace wall
}  // namespace runout
