// The gravity and materials sections.
#include "readers.hpp"

#include "runout/engine/rheology.hpp"

namespace runout::scene_reader {
namespace {

// One material: its name, its rheology by name, the bulk density and the rheology's own parameters, each
// key, default and range taken from the model's descriptor (engine/src/rheology/).
MaterialParams parse_material(const json& j, const std::string& path) {
  if (!j.is_object()) throw SceneError(path, "must be a JSON object");
  MaterialParams m;
  {
    Fields head(j, path, {"name", "rheology"}, /*partial=*/true);
    m.name = head.string("name");
    m.rheology = head.string("rheology", rheology_names());
  }
  const RheologyModel& model = rheology_model(m.rheology);
  std::set<std::string> allowed = {"name", "rheology", "density"};
  for (const auto& p : model.parameters) allowed.insert(p.key);
  Fields f(j, path, allowed);
  const ParameterSpec& rho = material_density_spec();
  m.density = f.number(rho.key, rho.lo, rho.hi, rho.lo_open, rho.hi_open);
  for (const auto& p : model.parameters) {
    if (p.required && !f.has(p.key))
      throw SceneError(f.at(p.key), "missing (required for rheology '" + m.rheology + "', in " + p.range_text() + ")");
    if (f.has(p.key)) m.set(p.key, f.number(p.key, p.lo, p.hi, p.lo_open, p.hi_open));
  }
  try {
    (void)make_rheology(m);
  } catch (const std::invalid_argument& e) {
    throw SceneError(path, e.what());
  }
  return m;
}

}  // namespace

template <int D>
void read_gravity(Build<D>& b) {
  SolverConfig& cfg = b.cfg;
  if (b.top.has("gravity")) {
    const auto g = b.top.vector("gravity", D, -1000.0, 1000.0);
    cfg.gravity = {0, 0, 0};
    for (int d = 0; d < D; ++d) cfg.gravity[d] = g[d];
  } else {
    cfg.gravity = {0, 0, 0};
    cfg.gravity[D - 1] = -9.81;
  }
  real g_mag = 0;
  for (int d = 0; d < D; ++d) g_mag += cfg.gravity[d] * cfg.gravity[d];
  b.g_mag = std::sqrt(g_mag);
}

// Materials (validated by the engine's rheology factories, which name the field).
template <int D>
void read_materials(Build<D>& b) {
  if (!b.top.has("materials")) throw SceneError("materials", "missing (required: an array of 1 to 16 materials)");
  const json& mats = b.top.raw("materials");
  if (!mats.is_array() || mats.empty() || mats.size() > 16)
    throw SceneError("materials", "must be an array of 1 to 16 materials");
  for (size_t k = 0; k < mats.size(); ++k) {
    MaterialParams m = parse_material(mats[k], "materials[" + std::to_string(k) + "]");
    if (b.material_index.count(m.name))
      throw SceneError("materials[" + std::to_string(k) + "].name", "duplicate material name '" + m.name + "'");
    b.material_index[m.name] = static_cast<uint16_t>(b.setup.materials.size());
    b.setup.materials.push_back(m);
  }
}

template void read_gravity<2>(Build<2>&);
template void read_gravity<3>(Build<3>&);
template void read_materials<2>(Build<2>&);
template void read_materials<3>(Build<3>&);

}  // namespace runout::scene_reader
