// Reading shapes shared by the sections (faces, boxes, polylines) and the build's shared state.
#include "readers.hpp"

namespace runout::scene_reader {

// Face names: x-, x+, y-, y+, (z-, z+), and "top"/"bottom" for the vertical axis.
template <int D>
FaceMask<D> parse_faces(const Fields& f, const std::string& key, FaceMask<D> mask) {
  if (!f.has(key)) return mask;
  const json& v = f.raw(key);
  if (!v.is_array()) throw SceneError(f.at(key), "must be an array of face names");
  const char axes[] = {'x', 'y', 'z'};
  for (size_t k = 0; k < v.size(); ++k) {
    const std::string field = f.at(key) + "[" + std::to_string(k) + "]";
    if (!v[k].is_string()) throw SceneError(field, "must be a face name");
    std::string s = v[k].get<std::string>();
    if (s == "top") s = std::string(1, axes[D - 1]) + "+";
    if (s == "bottom") s = std::string(1, axes[D - 1]) + "-";
    bool ok = false;
    for (int d = 0; d < D; ++d) {
      if (s.size() == 2 && s[0] == axes[d] && (s[1] == '-' || s[1] == '+')) {
        mask[d][s[1] == '+' ? 1 : 0] = true;
        ok = true;
      }
    }
    if (!ok) {
      std::string list;
      for (int d = 0; d < D; ++d) list += std::string(d ? ", " : "") + axes[d] + "-, " + axes[d] + "+";
      throw SceneError(field, "unknown face '" + s + "' (accepted: " + list + ", top, bottom)");
    }
  }
  return mask;
}

namespace {

FieldSpec vector_field(const std::string& key, real lo, real hi, bool lo_open, const std::string& doc) {
  FieldSpec f = shaped_field(key, "vector", doc, false);
  f.parameters = {{key, "m", 0.0, lo, hi, lo_open, false, false, "a component"}};
  return f;
}

}  // namespace

// The keys of a box; parse_box reads them with these ranges.
std::vector<FieldSpec> box_fields(const std::string& what) {
  return {vector_field("min", -1e7, 1e7, false, what + "'s lowest corner, with max (axis-aligned)"),
          vector_field("max", -1e7, 1e7, false, what + "'s highest corner, with min: above it on every axis"),
          vector_field("origin", -1e7, 1e7, false, what + "'s first corner, with size and angle (instead of min/max)"),
          vector_field("size", 0.0, 1e7, true, what + "'s extent along its own axes, from origin"),
          number_field({"angle", "degrees", 0.0, -90.0, 90.0, false, false, false,
                        "tilt: the box's local x turned downwards by this angle about origin (with origin/size)"})};
}

// A box: either {min, max} (axis-aligned) or {origin, size, angle}.
template <int D>
OrientedBox<D> parse_box(const Fields& f) {
  static const std::vector<FieldSpec> keys = box_fields("the box");
  auto vec = [&](const std::string& key) {
    const ParameterSpec& p = field_spec(keys, key).parameters.front();
    return to_vec<D>(f.vector(key, D, p.lo, p.hi));  // size > 0 is checked below, naming the rule
  };
  OrientedBox<D> box;
  if ((f.has("min") || f.has("max")) && (f.has("origin") || f.has("size") || f.has("angle")))
    throw SceneError(f.path(), "give the box either as min/max or as origin/size/angle, not both");
  if (f.has("min") || f.has("max")) {
    const Vec<D> lo = vec("min");
    const Vec<D> hi = vec("max");
    for (int d = 0; d < D; ++d)
      if (!(hi[d] > lo[d])) throw SceneError(f.at("max"), "must exceed min in every component");
    box.origin = lo;
    box.size = hi - lo;
  } else {
    box.origin = vec("origin");
    box.size = vec("size");
    for (int d = 0; d < D; ++d)
      if (!(box.size[d] > 0)) throw SceneError(f.at("size"), "every component must be > 0 m");
    box.angle_deg = read_parameter(f, field_spec(keys, "angle").parameters.front());
  }
  return box;
}

// A polyline or polygon: an array of [x, y] map coordinates.
terrain::Polyline parse_polyline(const json& v, const std::string& field, size_t min_points) {
  if (!v.is_array() || v.size() < min_points)
    throw SceneError(field, "must be an array of at least " + std::to_string(min_points) + " [x, y] points (map coordinates, m)");
  terrain::Polyline out;
  for (size_t k = 0; k < v.size(); ++k) {
    const std::string f = field + "[" + std::to_string(k) + "]";
    if (!v[k].is_array() || v[k].size() != 2) throw SceneError(f, "must be an [x, y] pair");
    out.push_back({Fields::check_number(v[k][0], f + "[0]", -1e8, 1e8, false, false),
                   Fields::check_number(v[k][1], f + "[1]", -1e8, 1e8, false, false)});
  }
  return out;
}

const std::set<std::string>& top_keys() {
  static const std::set<std::string> keys = {"name",     "dimensions", "dp",          "duration",   "gravity",
                                             "materials", "numerics",  "fluid",       "boundaries", "domain",
                                             "output",   "limits",     "description", "terrain",    "release",
                                             "structures", "protected_zones", "monitors", "fidelity", "inlets",
                                             "model",    "screening"};
  return keys;
}

const std::vector<FieldSpec>& top_fields() {
  static const std::vector<FieldSpec> fields = {
      number_field({"dp", "m", 0.0, 1e-4, 100.0, false, false, true, "particle spacing"}),
      number_field({"duration", "s", 0.0, 0.0, 1e5, true, false, true, "simulated time"})};
  return fields;
}

template <int D>
Build<D>::Build(const json& scene_json, Scene& s, const std::filesystem::path& dir)
    : j(scene_json), top(scene_json, "", top_keys()), scene(s), base_dir(dir), cfg(setup.config), dp(s.dp) {
  cfg.dp = dp;
}

template struct Build<2>;
template struct Build<3>;
template FaceMask<2> parse_faces<2>(const Fields&, const std::string&, FaceMask<2>);
template FaceMask<3> parse_faces<3>(const Fields&, const std::string&, FaceMask<3>);
template OrientedBox<2> parse_box<2>(const Fields&);
template OrientedBox<3> parse_box<3>(const Fields&);

}  // namespace runout::scene_reader
