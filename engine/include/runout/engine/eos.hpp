#pragma once
// The equation of state (Tait, thesis eq. 2.15), in one place: P = B ((rho / rho0)^gamma - 1) with
// B = c0^2 rho0 / gamma, and its inverse. The solver, the inlets, the density floor and the scene's
// hydrostatic start all use this.
#include <cmath>

#include "runout/engine/types.hpp"

namespace runout {

struct TaitEOS {
  real rho0 = 1000.0, B = 0.0, gamma = 7.0;

  TaitEOS() = default;
  TaitEOS(real speed_of_sound, real reference_density, real eos_gamma)
      : rho0(reference_density), B(speed_of_sound * speed_of_sound * reference_density / eos_gamma), gamma(eos_gamma) {}

  real pressure(real rho) const {
    const real x = rho / rho0;
    real xg;
    if (gamma == 7.0) {  // the default: four multiplications instead of pow
      const real x2 = x * x;
      xg = x2 * x2 * x2 * x;
    } else {
      xg = std::pow(x, gamma);
    }
    return B * (xg - 1.0);
  }
  // The density at pressure p (p > -B).
  real density(real p) const { return rho0 * std::pow(1.0 + p / B, 1.0 / gamma); }
};

}  // namespace runout
