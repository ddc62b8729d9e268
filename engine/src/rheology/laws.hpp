#pragma once
// Pieces the viscoplastic laws share.
#include <cmath>

#include "runout/engine/parameters.hpp"
#include "runout/engine/types.hpp"

namespace runout::rheology {

// (1 - exp(-m g)) / g, exact as g -> 0 (limit m) thanks to expm1.
inline real papanastasiou_factor(real m, real g) { return -std::expm1(-m * g) / g; }

// mu g^(n-1): pow is skipped when n == 1 (the common case) for speed and exactness.
inline real power_law(real mu, real n, real g) { return n == 1.0 ? mu : mu * std::pow(g, n - 1.0); }

// The consistency, flow index and regularisation of the Herschel-Bulkley-Papanastasiou family, declared once.
inline ParameterSpec consistency_spec() {
  return {"viscosity", "Pa s^n", 1e-3, 0.0, 1e8, false, false, false,
          "consistency mu (the dynamic viscosity when n = 1)"};
}
inline ParameterSpec flow_index_spec() {
  return {"flow_index", "", 1.0, 0.0, 5.0, true, false, false, "flow index n"};
}
inline ParameterSpec regularisation_spec() {
  return {"regularisation", "s", 100.0, 0.0, 1e8, true, false, false,
          "Papanastasiou m: the yield part is tau_y (1 - exp(-m |gamma_dot|)) / |gamma_dot|"};
}

}  // namespace runout::rheology
