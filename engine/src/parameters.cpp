#include "runout/engine/parameters.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace runout {

std::string format_number(real x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  std::string s = buf;
  // %g writes 1e+07 and 1e-05: drop the '+' and leading exponent zeros.
  const auto e = s.find('e');
  if (e == std::string::npos) return s;
  std::string mant = s.substr(0, e), exp = s.substr(e + 1);
  const bool neg = !exp.empty() && exp[0] == '-';
  if (!exp.empty() && (exp[0] == '+' || exp[0] == '-')) exp.erase(0, 1);
  while (exp.size() > 1 && exp[0] == '0') exp.erase(0, 1);
  return mant + "e" + (neg ? "-" : "") + exp;
}

bool ParameterSpec::accepts(real x) const {
  if (!std::isfinite(x)) return false;
  if (lo_open ? x <= lo : x < lo) return false;
  if (hi_open ? x >= hi : x > hi) return false;
  return true;
}

std::string ParameterSpec::range_text() const {
  std::string r = std::string(lo_open ? "(" : "[") + format_number(lo) + ", " + format_number(hi) + (hi_open ? ")" : "]");
  return unit.empty() ? r : r + " " + unit;
}

ParameterValues resolve_parameters(const std::vector<ParameterSpec>& specs, const ParameterValues& given,
                                   const std::string& path) {
  const std::string prefix = path.empty() ? "" : path + ".";
  for (const auto& [key, value] : given) {
    bool known = false;
    for (const auto& s : specs) known = known || s.key == key;
    if (known) continue;
    std::string accepted;
    for (const auto& s : specs) accepted += (accepted.empty() ? "" : ", ") + s.key;
    throw std::invalid_argument(prefix + key + ": unknown parameter (accepted: " +
                                (accepted.empty() ? "none" : accepted) + ")");
  }
  ParameterValues out;
  for (const auto& s : specs) {
    const auto it = given.find(s.key);
    if (it == given.end()) {
      if (s.required) throw std::invalid_argument(prefix + s.key + ": missing (required: a number in " + s.range_text() + ")");
      out[s.key] = s.default_value;
      continue;
    }
    if (!s.accepts(it->second))
      throw std::invalid_argument(prefix + s.key + ": must be in " + s.range_text() + " (got " +
                                  format_number(it->second) + ")");
    out[s.key] = it->second;
  }
  return out;
}

FieldSpec shaped_field(std::string key, std::string shape, std::string doc, bool required, int dimensions,
                       size_t min_points) {
  FieldSpec f;
  f.key = std::move(key);
  f.shape = std::move(shape);
  f.doc = std::move(doc);
  f.required = required;
  f.dimensions = dimensions;
  f.min_points = min_points;
  return f;
}

FieldSpec number_field(const ParameterSpec& p, int dimensions, std::string default_text) {
  FieldSpec f = shaped_field(p.key, "number", p.doc, p.required, dimensions);
  f.parameters = {p};
  f.default_text = std::move(default_text);
  return f;
}

const ParameterSpec& parameter_spec(const std::vector<ParameterSpec>& specs, const std::string& key) {
  for (const auto& p : specs)
    if (p.key == key) return p;
  throw std::invalid_argument("parameter_spec: '" + key + "' is not declared");
}

const FieldSpec& field_spec(const std::vector<FieldSpec>& fields, const std::string& key) {
  for (const auto& f : fields)
    if (f.key == key) return f;
  throw std::invalid_argument("field_spec: '" + key + "' is not declared");
}

}  // namespace runout
