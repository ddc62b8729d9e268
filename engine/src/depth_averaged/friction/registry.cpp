#include "registry.hpp"

#include <stdexcept>

#include "runout/engine/depth_averaged.hpp"

namespace runout::depth_averaged {
namespace friction {
#define RUNOUT_DECLARE_FRICTION(m) extern const FrictionModel m;
RUNOUT_BASAL_FRICTIONS(RUNOUT_DECLARE_FRICTION)
#undef RUNOUT_DECLARE_FRICTION
}  // namespace friction

const std::vector<const FrictionModel*>& friction_models() {
#define RUNOUT_LIST_FRICTION(m) &friction::m,
  static const std::vector<const FrictionModel*> models = {RUNOUT_BASAL_FRICTIONS(RUNOUT_LIST_FRICTION)};
#undef RUNOUT_LIST_FRICTION
  return models;
}

const FrictionModel& friction_model(const std::string& name) {
  for (const auto* m : friction_models())
    if (m->name == name) return *m;
  std::string accepted;
  for (const auto* m : friction_models()) accepted += (accepted.empty() ? "" : ", ") + m->name;
  throw std::invalid_argument("unknown basal friction '" + name + "' (accepted: " + accepted + ")");
}

std::unique_ptr<BasalFriction> make_friction(const std::string& name, const ParameterValues& given, real gravity,
                                             const std::string& path) {
  const FrictionModel* model = nullptr;
  try {
    model = &friction_model(name);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
  return model->create(resolve_parameters(model->parameters, given, path), gravity);
}

}  // namespace runout::depth_averaged
