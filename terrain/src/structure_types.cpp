// The structure types' registration list (each type in its own source under src/structures/) and what they
// share: how a structure's geometry is declared and how its numbers are read.
#include <sstream>

#include "structures/structure_steps.hpp"

namespace runout::terrain {

double StructureSpec::number(const std::string& key) const {
  const auto it = numbers.find(key);
  return it == numbers.end() ? 0.0 : it->second;
}

// The registration list: one line per structure type, in the order scenes and docs list them.
const std::vector<const StructureType*>& structure_types() {
  static const std::vector<const StructureType*> types = {
      &detail::check_dam_type(),
      &detail::deposition_area_type(),
      &detail::retention_basin_type(),
  };
  return types;
}

const StructureType& structure_type(const std::string& name) {
  return find_model(structure_types(), name, "structure type");
}

namespace detail {

FieldSpec geometry_field(const std::string& key, bool area, const std::string& doc) {
  return shaped_field(key, "polyline", doc, true, 0, area ? 3 : 2);
}

std::string message_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace detail
}  // namespace runout::terrain
