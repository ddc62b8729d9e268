#pragma once
// Basic numeric types shared by the engine. Dimension D is 2 or 3; the last axis is vertical.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace runout {

using real = double;

template <int D>
using Vec = Eigen::Matrix<real, D, 1>;

template <int D>
using Mat = Eigen::Matrix<real, D, D>;

constexpr real kPi = 3.14159265358979323846;

// Thrown for anything the solver refuses to continue with (NaN, leak, dt under the floor).
// The message names the simulated time, the particle and the quantity.
struct SimulationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace runout
