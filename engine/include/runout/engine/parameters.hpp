#pragma once
// Parameter descriptors: every model a scene chooses by name (a rheology, a kernel, a wall treatment, ...)
// declares its parameters once, here in this form, and the scene parser, the validators, `runout schema` and
// the docs' parameter tables all read them. Nothing else writes a model's keys, defaults or ranges.
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {

struct ParameterSpec {
  std::string key;            // as written in a scene (JSON key)
  std::string unit;           // SI unit as printed in messages and docs ("" for dimensionless)
  real default_value = 0.0;   // used when the key is absent (unless required)
  real lo = -std::numeric_limits<real>::infinity();
  real hi = std::numeric_limits<real>::infinity();
  bool lo_open = false, hi_open = false;
  bool required = false;
  std::string doc;            // one line
  bool integer = false;       // a whole number (read as one, refused otherwise)

  bool accepts(real x) const;
  // "[0, 90) deg", "(0, 1e8] s", "(0, 5]".
  std::string range_text() const;
};

// Parameter values by key, as a model receives them (every declared key present after resolve_parameters).
using ParameterValues = std::map<std::string, real>;

// Fills defaults and checks every value against its spec. Throws std::invalid_argument
// "<path>.<key>: ..." naming the accepted range (or, for an unknown key, the accepted keys).
ParameterValues resolve_parameters(const std::vector<ParameterSpec>& specs, const ParameterValues& given,
                                   const std::string& path);

// Numbers as messages and docs print them: 1e7, not 1e+07; 0.001; 28.
std::string format_number(real x);

}  // namespace runout
