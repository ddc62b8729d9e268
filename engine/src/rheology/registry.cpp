#include "registry.hpp"

#include <algorithm>
#include <stdexcept>

#include "runout/engine/rheology.hpp"

namespace runout {
namespace rheology {
#define RUNOUT_DECLARE_MODEL(m) extern const RheologyModel m;
RUNOUT_RHEOLOGIES(RUNOUT_DECLARE_MODEL)
#undef RUNOUT_DECLARE_MODEL
}  // namespace rheology

const std::vector<const RheologyModel*>& rheology_models() {
#define RUNOUT_LIST_MODEL(m) &rheology::m,
  static const std::vector<const RheologyModel*> models = {RUNOUT_RHEOLOGIES(RUNOUT_LIST_MODEL)};
#undef RUNOUT_LIST_MODEL
  return models;
}

std::vector<std::string> rheology_names() {
  std::vector<std::string> names;
  for (const auto* m : rheology_models()) names.push_back(m->name);
  std::sort(names.begin(), names.end());  // messages list them alphabetically
  return names;
}

const RheologyModel& rheology_model(const std::string& name) {
  for (const auto* m : rheology_models())
    if (m->name == name) return *m;
  std::string accepted;
  for (const auto& n : rheology_names()) accepted += (accepted.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown rheology '" + name + "' (accepted: " + accepted + ")");
}

const ParameterSpec& material_density_spec() {
  static const ParameterSpec spec{"density", "kg/m^3", 1000.0, 0.0, 1e5, true, false, true,
                                  "bulk density rho0 (the equation of state's reference density)"};
  return spec;
}

real MaterialParams::value(const std::string& key) const {
  if (const auto it = parameters.find(key); it != parameters.end()) return it->second;
  for (const auto& s : rheology_model(rheology).parameters)
    if (s.key == key) return s.default_value;
  throw std::invalid_argument("materials." + name + "." + key + ": not a parameter of rheology '" + rheology + "'");
}

std::unique_ptr<Rheology> make_rheology(const MaterialParams& params) {
  const std::string path = "materials." + params.name;
  const RheologyModel* model = nullptr;
  try {
    model = &rheology_model(params.rheology);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ".rheology: " + e.what());
  }
  const ParameterSpec& rho = material_density_spec();
  if (!rho.accepts(params.density))
    throw std::invalid_argument(path + ".density: must be in " + rho.range_text() + " (got " +
                                format_number(params.density) + ")");
  const ParameterValues values = resolve_parameters(model->parameters, params.parameters, path);
  try {
    return model->create(values, params.density);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + "." + e.what());
  }
}

}  // namespace runout
