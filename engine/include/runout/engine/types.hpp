#pragma once
// Basic numeric types shared by the engine. Dimension D is 2 or 3; the last axis is vertical.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
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
// `cause` and `leaked_particles` carry the same facts as values, so callers never parse the message.
struct SimulationError : std::runtime_error {
  enum class Cause { other, non_finite, dt_floor, density_floor, leak };
  explicit SimulationError(const std::string& what, Cause c = Cause::other, size_t leaked = 0)
      : std::runtime_error(what), cause(c), leaked_particles(leaked) {}
  Cause cause;
  size_t leaked_particles;  // particles past a wall or a closed face at the check that threw (cause == leak)
};

}  // namespace runout
