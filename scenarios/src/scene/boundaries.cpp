// The boundaries section: tanks, solid blocks, planes and flumes as wall particles with their leak regions;
// on terrain the ground and the walled structures come first (tag 1 the ground, then one per structure).
#include "boundary_types.hpp"

#include <algorithm>

namespace runout::scene_reader {

// The registration list: one line per boundary type, in the order scenes and docs list them.
const std::vector<const BoundaryType*>& boundary_types() {
  static const std::vector<const BoundaryType*> types = {
      &boundary_detail::tank_type(),
      &boundary_detail::block_type(),
      &boundary_detail::plane_type(),
      &boundary_detail::flume_type(),
  };
  return types;
}

const std::vector<FieldSpec>& boundary_common_fields() {
  static const std::vector<FieldSpec> fields = [] {
    FieldSpec tag = shaped_field("tag", "string", "the boundary's name in outputs (metrics.json boundary_tags)", false);
    tag.default_text = "the type and the index, e.g. \"tank0\"";
    return std::vector<FieldSpec>{
        tag, number_field({"layers", "", 3, 1, 10, false, false, false, "wall thickness in particle layers", true})};
  }();
  return fields;
}

namespace {

// The keys a boundary of `type` accepts in a scene of dimension D.
std::set<std::string> boundary_keys(const BoundaryType& type, int D) {
  std::set<std::string> allowed = {"type"};
  for (const auto* fields : {&boundary_common_fields(), &type.fields})
    for (const auto& f : *fields)
      if (f.dimensions == 0 || f.dimensions == D) allowed.insert(f.key);
  return allowed;
}

// Every key any boundary type has: an unknown key is refused listing them before the type is known.
std::set<std::string> any_boundary_keys() {
  std::set<std::string> keys = {"type"};
  for (const auto* t : boundary_types())
    for (const auto* fields : {&boundary_common_fields(), &t->fields})
      for (const auto& f : *fields) keys.insert(f.key);
  return keys;
}

template <int D>
void read_boundary(Build<D>& b, const json& j, size_t k) {
  const std::string path = item("boundaries", k);
  std::vector<std::string> names;
  for (const auto* t : boundary_types()) names.push_back(t->name);
  const BoundaryType& type =
      find_model(boundary_types(), Fields(j, path, any_boundary_keys()).string("type", names), "boundary type");
  Fields f(j, path, boundary_keys(type, D));
  const std::string tag_name = f.string_or("tag", type.name + std::to_string(k));
  const uint32_t tag = static_cast<uint32_t>(b.scene.boundary_tags.size());
  b.scene.boundary_tags.push_back(tag_name);
  const int layers = static_cast<int>(read_parameter(f, field_spec(boundary_common_fields(), "layers").parameters.front()));
  Walls<D> w{{}, b.setup.leak_regions, static_cast<int>(tag)};
  if constexpr (D == 2) type.make_2d(f, type, b.dp, layers, w);
  else type.make_3d(f, type, b.dp, layers, w);
  if (w.points.empty()) throw SceneError(path, "makes no boundary particles at dp = " + fmt(b.dp) + " m");
  for (const auto& p : w.points) {
    b.bparticles.push_back({p, tag});
    b.bottom = std::min(b.bottom, p[D - 1]);
  }
}

// Tag 1 is the ground (the bed's wall source); each walled structure has its own tag, in order.
template <int D>
void add_terrain_walls(Build<D>& b) {
  b.scene.boundary_tags.push_back("terrain");
  for (const auto& st : b.tmodel->structures)
    if (st.tag) b.scene.boundary_tags.push_back(st.name);
  if (b.make == Make::nothing) return;
  for (size_t q = 0; q < b.tmodel->boundary.size(); ++q) {
    Vec<D> p;
    for (int d = 0; d < D; ++d) p[d] = b.tmodel->boundary[q][d];
    b.bparticles.push_back({p, b.tmodel->boundary_tag[q]});
  }
  b.bed_source = terrain::bed_wall_source(b.tmodel);
}

}  // namespace

template <int D>
void read_boundaries(Build<D>& b) {
  b.scene.boundary_tags = {""};
  b.bottom = b.fluid_bottom;
  if (b.tmodel) add_terrain_walls(b);
  if (!b.top.has("boundaries")) return;
  const json& bs = b.top.raw("boundaries");
  if (!bs.is_array()) throw SceneError("boundaries", "must be an array of boundary objects");
  for (size_t k = 0; k < bs.size(); ++k) read_boundary(b, bs[k], k);
}

template void read_boundaries<2>(Build<2>&);
template void read_boundaries<3>(Build<3>&);

}  // namespace runout::scene_reader
