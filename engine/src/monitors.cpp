// The registration list of monitor types and the factory (each type in its own source under src/monitors/).
#include "runout/engine/monitors.hpp"

#include <stdexcept>

#include "monitors/monitor_types.hpp"

namespace runout {

// The registration list: one line per monitor type, in the order scenes and docs list them.
const std::vector<const MonitorType*>& monitor_types() {
  static const std::vector<const MonitorType*> types = {
      &monitor_detail::section_type(),
      &monitor_detail::structure_load_type(),
      &monitor_detail::pressure_probe_type(),
      &monitor_detail::face_pressure_type(),
      &monitor_detail::depth_gauge_type(),
  };
  return types;
}

const MonitorType& monitor_type(const std::string& name) { return find_model(monitor_types(), name, "monitor type"); }

real MonitorSpec::number(const std::string& key) const {
  const auto given = numbers.find(key);
  if (given != numbers.end()) return given->second;
  const FieldSpec& f = field_spec(monitor_type(type).fields, key);
  if (f.shape != "number") throw std::invalid_argument("monitor type '" + type + "': '" + key + "' is not a number");
  return f.parameters.front().default_value;
}

template <int D>
const std::map<std::string, MonitorFactory<D>>& monitor_registry() {
  static const std::map<std::string, MonitorFactory<D>> registry = [] {
    std::map<std::string, MonitorFactory<D>> r;
    for (const auto* t : monitor_types()) {
      if constexpr (D == 2) r[t->name] = t->make_2d;
      else r[t->name] = t->make_3d;
    }
    return r;
  }();
  return registry;
}

template <int D>
std::unique_ptr<Monitor<D>> make_monitor(const MonitorSpec& spec, const Solver<D>& solver) {
  const auto& reg = monitor_registry<D>();
  auto it = reg.find(spec.type);
  if (it == reg.end()) {
    std::string names;
    for (const auto& [n, f] : reg) names += (names.empty() ? "" : ", ") + n;
    throw std::invalid_argument("monitor '" + spec.name + "': unknown type '" + spec.type + "' (accepted: " + names + ")");
  }
  return it->second(spec, solver);
}

template const std::map<std::string, MonitorFactory<2>>& monitor_registry<2>();
template const std::map<std::string, MonitorFactory<3>>& monitor_registry<3>();
template std::unique_ptr<Monitor<2>> make_monitor<2>(const MonitorSpec&, const Solver<2>&);
template std::unique_ptr<Monitor<3>> make_monitor<3>(const MonitorSpec&, const Solver<3>&);

}  // namespace runout

