#pragma once
// Wall normals of fixed wall particles from their arrangement (wall_normals.cpp).
#include <array>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {
namespace solver_detail {

// One unit normal per particle of `pos` (sign arbitrary; zero where the neighbours within `radius` do not
// define one). period[d] > 0 makes axis d periodic with that length.
template <int D>
std::vector<Vec<D>> estimate_wall_normals(const std::array<std::vector<real>, D>& pos, real radius,
                                          const Vec<D>& period);

}  // namespace solver_detail
}  // namespace runout
