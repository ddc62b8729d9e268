#pragma once
// Parameter descriptors: every model a scene chooses by name (a rheology, a kernel, a wall treatment, ...)
// declares its parameters once, here in this form, and the scene parser, the validators, `runout schema` and
// the docs' parameter tables all read them. Nothing else writes a model's keys, defaults or ranges.
#include <limits>
#include <map>
#include <stdexcept>
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

// One key of a model that a scene names by type (a monitor, a structure): a number (with its ParameterSpec),
// or a piece of geometry, a name or a nested object, declared with its shape and doc so the scene parser,
// `runout schema` and the docs read the same list.
struct FieldSpec {
  std::string key;
  std::string shape;  // "number", "string", "polyline" ([x, y] points), "vector" (one number per axis),
                      // "object" (its members numbers), "indices" (whole numbers)
  std::string doc;    // one line
  bool required = false;
  int dimensions = 0;                     // 0: every scene; 2 or 3: only in a scene of that dimension
  size_t min_points = 0;                  // polyline: at least this many points
  std::vector<ParameterSpec> parameters;  // number: the number itself (one); object: its members
  std::string default_text;               // a default the model computes, said in words ("" = none or declared)
};

// A key of another shape (geometry, a name, an object): its members and computed default set afterwards.
FieldSpec shaped_field(std::string key, std::string shape, std::string doc, bool required = true, int dimensions = 0,
                       size_t min_points = 0);
// A number as a field: key, doc and required-ness taken from its ParameterSpec.
FieldSpec number_field(const ParameterSpec& p, int dimensions = 0, std::string default_text = "");

// The spec of `key` in a list (a FieldSpec's members, a model's parameters); throws std::invalid_argument.
const ParameterSpec& parameter_spec(const std::vector<ParameterSpec>& specs, const std::string& key);
const FieldSpec& field_spec(const std::vector<FieldSpec>& fields, const std::string& key);

// The model of a registration list with this name (a MonitorType, a StructureType, ...); throws
// std::invalid_argument "unknown <what> '<name>'".
template <class Model>
const Model& find_model(const std::vector<const Model*>& models, const std::string& name, const std::string& what) {
  for (const auto* m : models)
    if (m->name == name) return *m;
  throw std::invalid_argument("unknown " + what + " '" + name + "'");
}

// Parameter values by key, as a model receives them (every declared key present after resolve_parameters).
using ParameterValues = std::map<std::string, real>;

// Fills defaults and checks every value against its spec. Throws std::invalid_argument
// "<path>.<key>: ..." naming the accepted range (or, for an unknown key, the accepted keys).
ParameterValues resolve_parameters(const std::vector<ParameterSpec>& specs, const ParameterValues& given,
                                   const std::string& path);

// Numbers as messages and docs print them: 1e7, not 1e+07; 0.001; 28.
std::string format_number(real x);

}  // namespace runout
