#include "runout/scenarios/scene.hpp"

#include "runout/engine/eos.hpp"
#include "runout/terrain/terrain.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

namespace runout {
namespace {

using json = nlohmann::json;

std::string fmt(real v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Reads fields of one JSON object, refusing unknown keys and out-of-range values with the field's path.
class Fields {
 public:
  // partial: read a few fields of an object whose other keys another reader checks.
  Fields(const json& j, std::string path, std::set<std::string> allowed, bool partial = false)
      : j_(j), path_(std::move(path)) {
    if (!j_.is_object()) throw SceneError(path_.empty() ? "(root)" : path_, "must be a JSON object");
    for (auto it = j_.begin(); it != j_.end() && !partial; ++it) {
      if (!allowed.count(it.key())) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        throw SceneError(at(it.key()), "unknown field (accepted: " + list + ")");
      }
    }
  }
  std::string at(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  const std::string& path() const { return path_; }
  bool has(const std::string& key) const { return j_.contains(key) && !j_.at(key).is_null(); }
  const json& raw(const std::string& key) const {
    if (!has(key)) throw SceneError(at(key), "missing (required)");
    return j_.at(key);
  }

  // A finite number in [lo, hi] (open ends when the *_open flags are set).
  real number(const std::string& key, real lo, real hi, bool lo_open = false, bool hi_open = false) const {
    if (!has(key)) throw SceneError(at(key), "missing (required: a number in " + range(lo, hi, lo_open, hi_open) + ")");
    return check_number(j_.at(key), at(key), lo, hi, lo_open, hi_open);
  }
  real number_or(const std::string& key, real fallback, real lo, real hi, bool lo_open = false,
                 bool hi_open = false) const {
    return has(key) ? number(key, lo, hi, lo_open, hi_open) : fallback;
  }
  long integer(const std::string& key, long fallback, long lo, long hi) const {
    if (!has(key)) return fallback;
    const json& v = j_.at(key);
    if (!v.is_number_integer() && !(v.is_number() && std::floor(v.get<double>()) == v.get<double>()))
      throw SceneError(at(key), "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    const long x = static_cast<long>(v.get<double>());
    if (x < lo || x > hi)
      throw SceneError(at(key), "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return x;
  }
  std::string string(const std::string& key, const std::vector<std::string>& accepted = {}) const {
    if (!has(key) && !accepted.empty()) throw SceneError(at(key), "missing (required: one of " + join(accepted) + ")");
    const json& v = raw(key);
    if (!v.is_string()) throw SceneError(at(key), "must be a string");
    const std::string s = v.get<std::string>();
    check_choice(at(key), s, accepted);
    return s;
  }
  std::string string_or(const std::string& key, const std::string& fallback,
                        const std::vector<std::string>& accepted = {}) const {
    return has(key) ? string(key, accepted) : fallback;
  }
  bool boolean_or(const std::string& key, bool fallback) const {
    if (!has(key)) return fallback;
    if (!j_.at(key).is_boolean()) throw SceneError(at(key), "must be true or false");
    return j_.at(key).get<bool>();
  }
  // A vector of exactly n finite numbers.
  std::vector<real> vector(const std::string& key, int n, real lo = -1e7, real hi = 1e7) const {
    if (!has(key))
      throw SceneError(at(key), "missing (required: an array of " + std::to_string(n) + " numbers in " +
                                    range(lo, hi, false, false) + ")");
    const json& v = raw(key);
    if (!v.is_array() || static_cast<int>(v.size()) != n)
      throw SceneError(at(key), "must be an array of " + std::to_string(n) + " numbers");
    std::vector<real> out;
    for (int k = 0; k < n; ++k)
      out.push_back(check_number(v[k], at(key) + "[" + std::to_string(k) + "]", lo, hi, false, false));
    return out;
  }

  static std::string join(const std::vector<std::string>& names) {
    std::string list;
    for (const auto& a : names) list += (list.empty() ? "" : ", ") + a;
    return list;
  }
  static std::string range(real lo, real hi, bool lo_open, bool hi_open) {
    return std::string(lo_open ? "(" : "[") + fmt(lo) + ", " + fmt(hi) + (hi_open ? ")" : "]");
  }
  static void check_choice(const std::string& field, const std::string& s, const std::vector<std::string>& accepted) {
    if (accepted.empty()) return;
    for (const auto& a : accepted)
      if (a == s) return;
    std::string list;
    for (const auto& a : accepted) list += (list.empty() ? "" : ", ") + a;
    throw SceneError(field, "unknown value '" + s + "' (accepted: " + list + ")");
  }
  static real check_number(const json& v, const std::string& field, real lo, real hi, bool lo_open, bool hi_open) {
    const std::string r = range(lo, hi, lo_open, hi_open);
    if (!v.is_number()) throw SceneError(field, "must be a number in " + r);
    const real x = v.get<double>();
    if (!std::isfinite(x) || (lo_open ? x <= lo : x < lo) || (hi_open ? x >= hi : x > hi))
      throw SceneError(field, "must be a number in " + r + " (got " + fmt(x) + ")");
    return x;
  }

 private:
  json j_;  // a copy: callers pass temporaries (json::object() defaults)
  std::string path_;
};

template <int D>
Vec<D> to_vec(const std::vector<real>& v) {
  Vec<D> out;
  for (int d = 0; d < D; ++d) out[d] = v[d];
  return out;
}

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

// A box: either {min, max} (axis-aligned) or {origin, size, angle}.
template <int D>
OrientedBox<D> parse_box(const Fields& f) {
  OrientedBox<D> box;
  if ((f.has("min") || f.has("max")) && (f.has("origin") || f.has("size") || f.has("angle")))
    throw SceneError(f.path(), "give the box either as min/max or as origin/size/angle, not both");
  if (f.has("min") || f.has("max")) {
    const Vec<D> lo = to_vec<D>(f.vector("min", D));
    const Vec<D> hi = to_vec<D>(f.vector("max", D));
    for (int d = 0; d < D; ++d)
      if (!(hi[d] > lo[d])) throw SceneError(f.at("max"), "must exceed min in every component");
    box.origin = lo;
    box.size = hi - lo;
  } else {
    box.origin = to_vec<D>(f.vector("origin", D));
    box.size = to_vec<D>(f.vector("size", D, 0.0, 1e7));
    for (int d = 0; d < D; ++d)
      if (!(box.size[d] > 0)) throw SceneError(f.at("size"), "every component must be > 0 m");
    box.angle_deg = f.number_or("angle", 0.0, -90.0, 90.0);
  }
  return box;
}

// Lattice points of a box of extents e (the same floor rule as the geometry), for estimates.
real lattice_count(const std::vector<real>& e, real dp) {
  real n = 1;
  for (real x : e) n *= std::max<real>(0.0, std::floor(x / dp + 1e-9));
  return n;
}

// Estimate of the wall particles of one boundary object, from its JSON before validation (0 if unreadable:
// validation then refuses it). Tanks: the walls around the inside, open top; blocks: a shell `layers` deep;
// planes and flumes: the bed slab (and the flume's side walls).
real boundary_estimate(const json& b, int D, real dp) {
  auto num = [&](const char* key, real fallback) {
    return b.contains(key) && b[key].is_number() ? b[key].get<double>() : fallback;
  };
  auto extents = [&]() {
    std::vector<real> e(D, 0.0);
    for (int d = 0; d < D; ++d) {
      if (b.contains("size") && b["size"].is_array() && b["size"].size() > size_t(d) && b["size"][d].is_number())
        e[d] = b["size"][d].get<double>();
      else if (b.contains("min") && b.contains("max") && b["min"].is_array() && b["max"].is_array() &&
               b["min"].size() > size_t(d) && b["max"].size() > size_t(d) && b["min"][d].is_number() &&
               b["max"][d].is_number())
        e[d] = b["max"][d].get<double>() - b["min"][d].get<double>();
    }
    return e;
  };
  const real layers = std::clamp<real>(num("layers", 3), 1, 10);
  const std::string type = b.contains("type") && b["type"].is_string() ? b["type"].get<std::string>() : "";
  const real t = layers * dp;
  if (type == "tank") {
    std::vector<real> inner = extents(), outer = inner;
    for (int d = 0; d < D; ++d) outer[d] += (d == D - 1 ? 1 : 2) * t;
    return lattice_count(outer, dp) - lattice_count(inner, dp);
  }
  if (type == "block") {
    std::vector<real> outer = extents(), inner = outer;
    for (auto& x : inner) x = std::max<real>(0.0, x - 2 * t);
    return lattice_count(outer, dp) - lattice_count(inner, dp);
  }
  if (type == "plane" || type == "flume") {
    const real length = num("length", 0), width = D == 3 ? num("width", 0) : dp;
    real n = lattice_count({length, width, t}, dp);
    if (type == "flume" && D == 3) n += 2 * lattice_count({length, t, t + num("wall_height", 0)}, dp);
    return n;
  }
  return 0.0;
}

real box_volume_particles(const json& j, int D, real dp) {
  // Cheap estimate for the particle-count limit: bounding size / dp per axis.
  auto extent = [&](int d) -> real {
    if (j.contains("size") && j["size"].is_array() && j["size"].size() > static_cast<size_t>(d) &&
        j["size"][d].is_number())
      return j["size"][d].get<double>();
    if (j.contains("min") && j.contains("max") && j["min"].is_array() && j["max"].is_array() &&
        j["min"].size() > static_cast<size_t>(d) && j["max"].size() > static_cast<size_t>(d) &&
        j["min"][d].is_number() && j["max"][d].is_number())
      return j["max"][d].get<double>() - j["min"][d].get<double>();
    return 0.0;
  };
  real n = 1;
  for (int d = 0; d < D; ++d) n *= std::max<real>(0.0, extent(d) / dp);
  return n;
}

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

const std::vector<std::string> kTopKeys = {"name",   "dimensions", "dp",     "duration", "gravity", "materials",
                                           "numerics", "fluid",    "boundaries", "domain", "output", "limits",
                                           "description", "terrain", "release", "structures",
                                           "protected_zones", "monitors", "fidelity", "inlets"};

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

// The terrain, release, structures and protected_zones sections (docs/scene-format.md, "Terrain scenes").
terrain::TerrainSpec parse_terrain_spec(const json& j, const std::filesystem::path& base_dir) {
  terrain::TerrainSpec spec;
  Fields t(j.at("terrain"), "terrain", {"dem", "crs", "resolution", "layers", "corridor"});
  std::filesystem::path dem = t.string("dem");
  if (dem.is_relative() && !base_dir.empty()) dem = base_dir / dem;
  spec.dem_path = dem.string();
  spec.dem.target_crs = t.string_or("crs", "");
  spec.dem.resolution = t.number_or("resolution", 0.0, 0.0, 1e4);
  spec.layers = static_cast<int>(t.integer("layers", 3, 2, 10));
  if (t.has("corridor")) {
    Fields c(t.raw("corridor"), "terrain.corridor", {"travel_angle", "buffer", "polygon", "max_outflow"});
    spec.corridor.travel_angle_deg = c.number_or("travel_angle", 11.0, 0.0, 60.0, true);
    spec.corridor.buffer_m = c.number_or("buffer", 0.0, 0.0, 1e5);
    if (c.has("polygon")) spec.corridor.polygon = parse_polyline(c.raw("polygon"), c.at("polygon"), 3);
    spec.corridor.max_outflow = c.number_or("max_outflow", 0.01, 0.0, 1.0);
  }
  if (!j.contains("release")) throw SceneError("release", "missing (required in a terrain scene: polygon, depth or volume, material)");
  Fields r(j.at("release"), "release", {"polygon", "depth", "volume", "material"});
  spec.release.polygon = parse_polyline(r.raw("polygon"), r.at("polygon"), 3);
  if (r.has("depth") == r.has("volume"))
    throw SceneError("release", "give exactly one of depth (m, in (0, 1000]) or volume (m3, in (0, 1e9])");
  spec.release.depth = r.number_or("depth", 0.0, 0.0, 1000.0, true);
  spec.release.volume = r.number_or("volume", 0.0, 0.0, 1e9, true);
  if (j.contains("structures")) {
    const json& ss = j.at("structures");
    if (!ss.is_array()) throw SceneError("structures", "must be an array of structures");
    std::set<std::string> names;
    for (size_t k = 0; k < ss.size(); ++k) {
      const std::string path = "structures[" + std::to_string(k) + "]";
      const std::string type = Fields(ss[k], path,
                                      {"type", "name", "axis", "polygon", "crest_height", "thickness", "slit",
                                       "elevation", "gradient", "depth", "wall_height", "wall_thickness",
                                       "open_edges"})
                                   .string("type", {"check_dam", "deposition_area", "retention_basin"});
      std::set<std::string> allowed = {"type", "name"};
      if (type == "check_dam") allowed.insert({"axis", "crest_height", "thickness", "slit"});
      if (type == "deposition_area") allowed.insert({"polygon", "elevation", "gradient"});
      if (type == "retention_basin") allowed.insert({"polygon", "depth", "wall_height", "wall_thickness", "open_edges"});
      Fields f(ss[k], path, allowed);
      terrain::StructureSpec st;
      st.name = f.string("name");
      if (!names.insert(st.name).second) throw SceneError(f.at("name"), "duplicate structure name '" + st.name + "'");
      if (type == "check_dam") {
        st.kind = terrain::StructureKind::check_dam;
        st.line = parse_polyline(f.raw("axis"), f.at("axis"), 2);
        st.crest_height = f.number("crest_height", 0.0, 200.0, true);
        st.thickness = f.number("thickness", 0.0, 100.0, true);
        if (f.has("slit")) {
          Fields sl(f.raw("slit"), f.at("slit"), {"width", "bottom"});
          st.slit_width = sl.number("width", 0.0, 1000.0, true);
          st.slit_bottom = sl.number_or("bottom", 0.0, 0.0, 200.0);
          if (st.slit_bottom >= st.crest_height)
            throw SceneError(sl.at("bottom"), "must be below crest_height (" + fmt(st.crest_height) + " m)");
        }
      } else if (type == "deposition_area") {
        st.kind = terrain::StructureKind::deposition_area;
        st.line = parse_polyline(f.raw("polygon"), f.at("polygon"), 3);
        if (f.has("elevation")) st.elevation = f.number("elevation", -500.0, 9000.0);
        st.gradient = f.number_or("gradient", 0.0, 0.0, 1.0);
      } else {
        st.kind = terrain::StructureKind::retention_basin;
        st.line = parse_polyline(f.raw("polygon"), f.at("polygon"), 3);
        st.depth = f.number_or("depth", 0.0, 0.0, 100.0);
        st.wall_height = f.number_or("wall_height", 0.0, 0.0, 100.0);
        if (!(st.depth > 0) && !(st.wall_height > 0))
          throw SceneError(path, "a retention basin needs depth > 0 m or wall_height > 0 m (or both)");
        if (st.wall_height > 0) st.wall_thickness = f.number("wall_thickness", 0.0, 100.0, true);
        if (f.has("open_edges")) {
          const json& oe = f.raw("open_edges");
          if (!oe.is_array()) throw SceneError(f.at("open_edges"), "must be an array of edge indices");
          std::vector<int> edges;
          for (size_t q = 0; q < oe.size(); ++q) {
            const std::string ef = f.at("open_edges") + "[" + std::to_string(q) + "]";
            if (!oe[q].is_number_integer() || oe[q].get<long>() < 0 || oe[q].get<long>() >= static_cast<long>(st.line.size()))
              throw SceneError(ef, "must be an edge index in [0, " + std::to_string(st.line.size() - 1) +
                                       "] (edge k joins vertex k to vertex k+1)");
            edges.push_back(oe[q].get<int>());
          }
          st.open_edges = edges;
        }
      }
      spec.structures.push_back(std::move(st));
    }
  }
  if (j.contains("protected_zones")) {
    const json& zs = j.at("protected_zones");
    if (!zs.is_array()) throw SceneError("protected_zones", "must be an array of {name, polygon}");
    for (size_t k = 0; k < zs.size(); ++k) {
      Fields z(zs[k], "protected_zones[" + std::to_string(k) + "]", {"name", "polygon"});
      spec.protected_zones.push_back({z.string("name"), parse_polyline(z.raw("polygon"), z.at("polygon"), 3)});
    }
  }
  return spec;
}

template <int D>
Scene build(const json& j, Scene scene, const std::filesystem::path& base_dir) {
  Fields top(j, "", std::set<std::string>(kTopKeys.begin(), kTopKeys.end()));
  SceneSetup<D> setup;
  SolverConfig& cfg = setup.config;
  const real dp = scene.dp;
  cfg.dp = dp;

  // Gravity.
  if (top.has("gravity")) {
    const auto g = top.vector("gravity", D, -1000.0, 1000.0);
    cfg.gravity = {0, 0, 0};
    for (int d = 0; d < D; ++d) cfg.gravity[d] = g[d];
  } else {
    cfg.gravity = {0, 0, 0};
    cfg.gravity[D - 1] = -9.81;
  }
  real g_mag = 0;
  for (int d = 0; d < D; ++d) g_mag += cfg.gravity[d] * cfg.gravity[d];
  g_mag = std::sqrt(g_mag);

  // Materials (validated by the engine's rheology factories, which name the field).
  if (!top.has("materials")) throw SceneError("materials", "missing (required: an array of 1 to 16 materials)");
  const json& mats = top.raw("materials");
  if (!mats.is_array() || mats.empty() || mats.size() > 16)
    throw SceneError("materials", "must be an array of 1 to 16 materials");
  std::map<std::string, uint16_t> material_index;
  for (size_t k = 0; k < mats.size(); ++k) {
    MaterialParams m = parse_material(mats[k], "materials[" + std::to_string(k) + "]");
    if (material_index.count(m.name))
      throw SceneError("materials[" + std::to_string(k) + "].name", "duplicate material name '" + m.name + "'");
    material_index[m.name] = static_cast<uint16_t>(setup.materials.size());
    setup.materials.push_back(m);
  }

  // Particle-count limit, checked on an estimate before any particle is made.
  {
    Fields lim(j.contains("limits") ? j["limits"] : json::object(), "limits", {"max_particles"});
    scene.max_particles = lim.integer("max_particles", scene.max_particles, 1, 200'000'000);
    real est = 0;
    if (j.contains("fluid") && j["fluid"].is_array())
      for (const auto& b : j["fluid"]) est += box_volume_particles(b, D, dp);
    if (j.contains("boundaries") && j["boundaries"].is_array())
      for (const auto& b : j["boundaries"]) est += boundary_estimate(b, D, dp);
    if (est > static_cast<real>(scene.max_particles))
      throw SceneError("dp", "the geometry at dp = " + fmt(dp) + " m needs about " + fmt(std::round(est)) +
                                 " particles, over limits.max_particles = " + std::to_string(scene.max_particles) +
                                 " (raise dp or the limit)");
  }

  // Terrain: built first (it validates the DEM, release and structures), its release joins the fluid.
  std::shared_ptr<terrain::TerrainModel> tmodel;
  std::string release_material;
  for (const char* key : {"release", "structures", "protected_zones"})
    if (top.has(key) && !top.has("terrain")) throw SceneError(key, "needs a terrain section");
  if (top.has("terrain")) {
    if (D != 3) throw SceneError("dimensions", "a terrain scene must have dimensions = 3");
    const terrain::TerrainSpec spec = parse_terrain_spec(j, base_dir);
    release_material = Fields(j.at("release"), "release", {"polygon", "depth", "volume", "material"}).string("material");
    if (!material_index.count(release_material))
      throw SceneError("release.material", "no material named '" + release_material + "'");
    try {
      tmodel = std::make_shared<terrain::TerrainModel>(terrain::build_terrain(spec, dp, scene.max_particles));
    } catch (const terrain::TerrainError& e) {
      const std::string what = e.what();
      throw SceneError(e.field, what.substr(std::min(what.size(), e.field.size() + 2)));
    }
  }

  // Fluid blocks (none needed when inlets bring the flow in).
  const bool has_inlets = top.has("inlets");
  if (!top.has("fluid") && !tmodel && !has_inlets)
    throw SceneError("fluid", "missing (required: a non-empty array of fluid blocks, or inlets)");
  const json& fluid = top.has("fluid") ? top.raw("fluid") : json::array();
  if (!fluid.is_array() || (fluid.empty() && !tmodel && !has_inlets))
    throw SceneError("fluid", "must be a non-empty array of fluid blocks");
  real fluid_top = -1e300, fluid_bottom = 1e300;
  struct PendingFluid {
    Lattice<D> lattice;
    uint16_t material;
  };
  std::vector<PendingFluid> pending;
  for (size_t k = 0; k < fluid.size(); ++k) {
    const std::string path = "fluid[" + std::to_string(k) + "]";
    Fields f(fluid[k], path, {"shape", "min", "max", "origin", "size", "angle", "material"});
    f.string_or("shape", "box", {"box"});
    const OrientedBox<D> box = parse_box<D>(f);
    const std::string mat = f.string("material");
    if (!material_index.count(mat)) {
      std::vector<std::string> names;
      for (const auto& m : setup.materials) names.push_back(m.name);
      throw SceneError(f.at("material"), "no material named '" + mat + "' (defined: " + Fields::join(names) + ")");
    }
    Lattice<D> lat = fill_box<D>(box, dp);
    if (lat.points.empty()) throw SceneError(path, "block is thinner than dp = " + fmt(dp) + " m");
    for (const auto& p : lat.points) {
      fluid_top = std::max(fluid_top, p[D - 1] + 0.5 * dp);
      fluid_bottom = std::min(fluid_bottom, p[D - 1] - 0.5 * dp);
    }
    pending.push_back({std::move(lat), material_index[mat]});
  }
  if (tmodel) {
    Lattice<D> lat;
    for (size_t q = 0; q < tmodel->fluid.size(); ++q) {
      Vec<D> p;
      for (int d = 0; d < D; ++d) p[d] = tmodel->fluid[q][d];
      lat.points.push_back(p);
      lat.depth.push_back(tmodel->fluid_depth[q]);
      fluid_top = std::max(fluid_top, p[D - 1] + 0.5 * dp);
      fluid_bottom = std::min(fluid_bottom, p[D - 1] - 0.5 * dp);
    }
    pending.push_back({std::move(lat), material_index[release_material]});
  }

  // Inlets: velocity inlets across a vertical plane (engine InletSpec); the speed is given, or the discharge
  // over the opening's area as the buffer fills it (whole particles: floor(size / dp) per axis).
  real inlet_speed_max = 0;
  if (has_inlets) {
    if (tmodel) throw SceneError("inlets", "inlets are for scenes without terrain (flumes, channels) in this version");
    const json& ins = top.raw("inlets");
    if (!ins.is_array() || ins.empty()) throw SceneError("inlets", "must be a non-empty array of inlet objects");
    std::vector<std::string> dirs = {"+x", "-x"};
    if (D == 3) dirs.insert(dirs.end(), {"+y", "-y"});
    for (size_t k = 0; k < ins.size(); ++k) {
      const std::string path = "inlets[" + std::to_string(k) + "]";
      Fields f(ins[k], path, {"name", "material", "direction", "at", "min", "max", "speed", "discharge"});
      InletSpec<D> in;
      in.name = f.string_or("name", "inlet" + std::to_string(k + 1));
      const std::string mat = f.string("material");
      if (!material_index.count(mat)) throw SceneError(f.at("material"), "no material named '" + mat + "'");
      in.material = material_index[mat];
      const std::string dir = f.string("direction", dirs);
      in.axis = dir[1] == 'x' ? 0 : 1;
      in.direction = dir[0] == '+' ? 1 : -1;
      in.at = f.number("at", -1e7, 1e7);
      const auto lo = f.vector("min", D - 1), hi = f.vector("max", D - 1);
      real area = 1;
      for (int a = 0; a < D - 1; ++a) {
        in.lo[a] = lo[a];
        in.hi[a] = hi[a];
        const real n = std::floor((hi[a] - lo[a]) / dp + 1e-9);
        if (n < 1)
          throw SceneError(f.at("max"), "must exceed min by at least dp = " + fmt(dp) + " m on every axis (got " +
                                            fmt(hi[a] - lo[a]) + " m)");
        area *= n * dp;
      }
      if (f.has("speed") == f.has("discharge"))
        throw SceneError(path, "give exactly one of speed (m/s) and discharge (m3/s; m2/s in 2D)");
      const std::string key = f.has("speed") ? "speed" : "discharge";
      const real scale = key == "speed" ? 1.0 : 1.0 / area;
      const json& v = f.raw(key);
      if (v.is_number()) {
        in.speed.push_back({0.0, scale * Fields::check_number(v, f.at(key), 0.0, 1e6, false, false)});
      } else if (v.is_array() && !v.empty()) {
        for (size_t q = 0; q < v.size(); ++q) {
          const std::string at = f.at(key) + "[" + std::to_string(q) + "]";
          if (!v[q].is_array() || v[q].size() != 2)
            throw SceneError(at, "must be a [t (s), value] pair");
          const real t = Fields::check_number(v[q][0], at + "[0]", 0.0, 1e7, false, false);
          if (q > 0 && !(t > in.speed.back()[0])) throw SceneError(at + "[0]", "times must increase");
          in.speed.push_back({t, scale * Fields::check_number(v[q][1], at + "[1]", 0.0, 1e6, false, false)});
        }
      } else {
        throw SceneError(f.at(key), "must be a number >= 0 or an array of [t, value] pairs (a hydrograph)");
      }
      for (const auto& sp : in.speed) inlet_speed_max = std::max(inlet_speed_max, sp[1]);
      fluid_top = std::max(fluid_top, in.hi[D - 2]);
      fluid_bottom = std::min(fluid_bottom, in.lo[D - 2]);
      setup.inlets.push_back(std::move(in));
    }
  }

  // Boundaries.
  scene.boundary_tags = {""};
  std::vector<std::pair<Vec<D>, uint32_t>> bparticles;
  real bottom = fluid_bottom;
  if (tmodel) {
    // Tag 1 is the ground; each walled structure has its own tag, in order.
    scene.boundary_tags.push_back("terrain");
    for (const auto& st : tmodel->structures)
      if (st.tag) scene.boundary_tags.push_back(st.name);
    for (size_t q = 0; q < tmodel->boundary.size(); ++q) {
      Vec<D> p;
      for (int d = 0; d < D; ++d) p[d] = tmodel->boundary[q][d];
      bparticles.push_back({p, tmodel->boundary_tag[q]});
    }
  }
  if (top.has("boundaries")) {
    const json& bs = top.raw("boundaries");
    if (!bs.is_array()) throw SceneError("boundaries", "must be an array of boundary objects");
    for (size_t k = 0; k < bs.size(); ++k) {
      const std::string path = "boundaries[" + std::to_string(k) + "]";
      const std::string type =
          Fields(bs[k], path,
                 {"type", "tag", "min", "max", "origin", "size", "angle", "layers", "open", "length", "width",
                  "wall_height"})
              .string("type", {"tank", "block", "plane", "flume"});
      std::set<std::string> allowed = {"type", "tag", "layers", "angle"};
      if (type == "tank" || type == "block") allowed.insert({"min", "max", "origin", "size"});
      if (type == "tank") allowed.insert("open");
      if (type == "plane" || type == "flume") allowed.insert({"origin", "length"});
      if (D == 3 && (type == "plane" || type == "flume")) allowed.insert("width");
      if (D == 3 && type == "flume") allowed.insert("wall_height");
      Fields f(bs[k], path, allowed);
      const std::string tag_name = f.string_or("tag", type + std::to_string(k));
      const uint32_t tag = static_cast<uint32_t>(scene.boundary_tags.size());
      scene.boundary_tags.push_back(tag_name);
      const int layers = static_cast<int>(f.integer("layers", 3, 1, 10));
      std::vector<Vec<D>> pts;
      FaceMask<D> none{};
      if (type == "tank") {
        FaceMask<D> open{};
        open[D - 1][1] = true;
        open = parse_faces<D>(f, "open", f.has("open") ? FaceMask<D>{} : open);
        const OrientedBox<D> inner = parse_box<D>(f);
        pts = tank_walls<D>(inner, dp, layers, open);
        auto regions = tank_leak_regions<D>(inner, dp, layers, open, static_cast<int>(tag));
        setup.leak_regions.insert(setup.leak_regions.end(), regions.begin(), regions.end());
      } else if (type == "block") {
        const OrientedBox<D> box = parse_box<D>(f);
        pts = solid_box_shell<D>(box, dp, layers, none);
        auto regions = solid_box_leak_regions<D>(box, dp, none, static_cast<int>(tag));
        setup.leak_regions.insert(setup.leak_regions.end(), regions.begin(), regions.end());
      } else {  // plane or flume: a bed slab under a surface line starting at `origin`
        const Vec<D> origin = to_vec<D>(f.vector("origin", D));
        const real length = f.number("length", 0.0, 1e6, true);
        const real width = D == 3 ? f.number("width", 0.0, 1e6, true) : 0.0;
        const real angle = f.number_or("angle", 0.0, -89.0, 89.0);
        const real t = layers * dp;
        auto slab = [&](real x0, real x1, real y0, real y1, real z0, real z1) {
          OrientedBox<D> b;
          b.angle_deg = angle;
          Vec<D> lo = Vec<D>::Zero();
          lo[0] = x0;
          lo[D - 1] = z0;
          if constexpr (D == 3) lo[1] = y0;
          b.origin = origin;
          b.origin = b.to_world(lo);
          b.size[0] = x1 - x0;
          b.size[D - 1] = z1 - z0;
          if constexpr (D == 3) b.size[1] = y1 - y0;
          auto p = solid_box_shell<D>(b, dp, 1000, none);
          pts.insert(pts.end(), p.begin(), p.end());
          auto regions = solid_box_leak_regions<D>(b, dp, none, static_cast<int>(tag));
          setup.leak_regions.insert(setup.leak_regions.end(), regions.begin(), regions.end());
        };
        slab(0, length, 0, width, -t, 0);
        if (type == "flume" && D == 3) {
          const real wall_h = f.number("wall_height", 0.0, 1e4, true);
          slab(0, length, -t, 0, -t, wall_h);
          slab(0, length, width, width + t, -t, wall_h);
        }
      }
      if (pts.empty()) throw SceneError(path, "makes no boundary particles at dp = " + fmt(dp) + " m");
      for (const auto& p : pts) {
        bparticles.push_back({p, tag});
        bottom = std::min(bottom, p[D - 1]);
      }
    }
  }

  // Fluid must start outside every wall (inside one it leaks on the first step) and blocks must not overlap.
  for (size_t k = 0; k < pending.size(); ++k) {
    for (const auto& p : pending[k].lattice.points) {
      for (const auto& r : setup.leak_regions) {
        if (!r.contains(p)) continue;
        std::ostringstream s;
        s << "a particle at (";
        for (int d = 0; d < D; ++d) s << (d ? ", " : "") << p[d];
        s << ") m starts inside the wall of boundaries[" << r.tag - 1 << "] ('" << scene.boundary_tags[r.tag]
          << "'): fluid must start outside walls";
        throw SceneError("fluid[" + std::to_string(k) + "]", s.str());
      }
    }
  }
  if (pending.size() > 1) {
    // Cells of size dp: two particles closer than dp/2 are in the same or a neighbouring cell.
    std::map<std::array<long, D>, std::vector<std::pair<size_t, Vec<D>>>> cells;
    auto cell_of = [&](const Vec<D>& p) {
      std::array<long, D> c;
      for (int d = 0; d < D; ++d) c[d] = static_cast<long>(std::floor(p[d] / dp));
      return c;
    };
    for (size_t k = 0; k < pending.size(); ++k) {
      for (const auto& p : pending[k].lattice.points) {
        const auto c = cell_of(p);
        for (int o = 0; o < (D == 2 ? 9 : 27); ++o) {
          std::array<long, D> n = c;
          int rem = o;
          for (int d = 0; d < D; ++d, rem /= 3) n[d] += rem % 3 - 1;
          auto it = cells.find(n);
          if (it == cells.end()) continue;
          for (const auto& [other, q] : it->second)
            if (other != k && (q - p).norm() < 0.5 * dp)
              throw SceneError("fluid[" + std::to_string(k) + "]",
                               "overlaps fluid[" + std::to_string(other) + "]: fluid blocks must not overlap");
        }
        cells[c].push_back({k, p});
      }
    }
  }

  // Numerics.
  Fields num(j.contains("numerics") ? j["numerics"] : json::object(), "numerics",
             {"kernel", "smoothing_ratio", "speed_of_sound", "speed_of_sound_beta", "depth_scale", "integrator",
              "cfl", "density_diffusion", "density_diffusion_delta", "artificial_viscosity", "viscosity_cap",
              "viscosity_cap_factor", "shear_rate_floor", "min_dt", "boundary_density", "verlet_reset_steps", "boundary_pressure",
              "density_floor", "max_dilatancy"});
  // The plain numbers: key, default and range from the engine's descriptors (numerics_parameters()).
  auto numeric = [&num](const char* key) -> real {
    const ParameterSpec& p = numerics_parameter(key);
    if (p.integer) return static_cast<real>(num.integer(key, static_cast<long>(p.default_value), static_cast<long>(p.lo),
                                                        static_cast<long>(p.hi)));
    return num.number_or(key, p.default_value, p.lo, p.hi, p.lo_open, p.hi_open);
  };
  cfg.kernel = kernel_from_name(num.string_or("kernel", kernel_names().front(), kernel_names()));
  cfg.smoothing_length = numeric("smoothing_ratio") * dp;
  cfg.integrator = integrator_from_name(num.string_or("integrator", "symplectic", integrator_names()));
  cfg.verlet_reset_steps = static_cast<int>(numeric("verlet_reset_steps"));
  cfg.cfl = numeric("cfl");
  cfg.density_diffusion = density_diffusion_from_name(num.string_or("density_diffusion", "fourtakas", density_diffusion_names()));
  cfg.density_diffusion_delta = numeric("density_diffusion_delta");
  cfg.artificial_viscosity = numeric("artificial_viscosity");
  // c0: explicit, or beta sqrt(g H) with H the depth scale (default: fluid top to the lowest particle).
  // On terrain the lowest particle is far down the valley, not under the flow. There the speed scale is the
  // energy line's: a block sliding at the travel angle reaches sqrt(2 g E) with E the energy height, and
  // c0 = beta max(sqrt(g d), sqrt(2 g E)) keeps the Mach number under 1/beta (conservative: the real flow
  // loses more than the travel angle says). An explicit speed_of_sound trades that margin for speed.
  const real default_depth = tmodel ? std::max<real>(tmodel->release_depth, dp) : std::max(fluid_top - bottom, dp);
  const real depth_scale = num.number_or("depth_scale", default_depth, 0.0, 1e5, true);
  const real beta = numeric("speed_of_sound_beta");
  real speed_scale = std::sqrt(std::max(g_mag, 1e-3) * depth_scale);
  if (tmodel && !num.has("depth_scale"))
    speed_scale = std::max(speed_scale, std::sqrt(2.0 * std::max(g_mag, 1e-3) * tmodel->max_energy_height));
  speed_scale = std::max(speed_scale, inlet_speed_max);  // inflow faster than its sqrt(g H)
  cfg.speed_of_sound = num.has("speed_of_sound") ? num.number("speed_of_sound", 0.0, 1e5, true) : beta * speed_scale;
  if (num.has("viscosity_cap")) {
    const json& cap = num.raw("viscosity_cap");
    if (cap.is_string()) {
      Fields::check_choice(num.at("viscosity_cap"), cap.get<std::string>(), {"auto"});
      cfg.max_viscosity = 0;
    } else {
      cfg.max_viscosity = Fields::check_number(cap, num.at("viscosity_cap"), 0.0, 1e12, true, false);
    }
  }
  cfg.viscosity_cap_factor = numeric("viscosity_cap_factor");
  cfg.shear_rate_floor = numeric("shear_rate_floor");
  cfg.min_dt = numeric("min_dt");
  cfg.density_floor = num.boolean_or("density_floor", false);
  cfg.max_dilatancy = numeric("max_dilatancy");
  if (num.has("max_dilatancy") && !cfg.density_floor)
    throw SceneError(num.at("max_dilatancy"), "sets how far under rho0 the density floor stands: needs numerics.density_floor = true");
  // Inlets need walls without memory: a DBC wall particle under a buffer that moves over it gains density
  // from the one-sided inflow at the plane and never loses it (its density is floored at rho0), until it
  // throws the new flow off the bed (measured: tests/engine/inlet_test.cpp detaches at t < 0.2 s with dbc).
  const std::string bp_default = setup.inlets.empty() ? "dbc" : "extrapolated";
  cfg.boundary_pressure =
      boundary_pressure_from_name(num.string_or("boundary_pressure", bp_default, boundary_pressure_names()));
  if (!setup.inlets.empty() && cfg.boundary_pressure == BoundaryPressure::dbc)
    throw SceneError("numerics.boundary_pressure", "must be 'extrapolated' in a scene with inlets (accepted: extrapolated)");
  cfg.boundary_density = num.number_or("boundary_density", setup.materials[0].density, 0.0, 1e5, true);
  if (cfg.integrator == Integrator::verlet) {
    // Verlet's leapfrog (v_{n+1} = v_{n-1} + 2 dt a_n) has a computational mode that a viscous force taken at
    // level n drives unstably; the Euler step every verlet_reset_steps holds it down for a liquid's viscosity,
    // not for a viscoplastic material, whose mu_eff sits at the cap (at the viscous time-step limit) wherever
    // it rests. Measured: a friction column blew up within 5 ms, a Bingham channel reached Mach 1.3, a plain
    // HBP column Mach 0.43 against 0.05 (docs/design.md, "Time stepping and guards").
    for (const auto& m : setup.materials)
      if (!rheology_model(m.rheology).traits.verlet_stable)
        throw SceneError(num.at("integrator"),
                         "verlet cannot carry material '" + m.name + "' (" + m.rheology +
                             "): its effective viscosity reaches the cap where it rests, and Verlet's leapfrog is "
                             "unstable under it; use symplectic (accepted here: symplectic)");
  }

  // Fluid particles, with a hydrostatic initial density (less start-up shock than rho0 everywhere).
  for (const auto& pf : pending) {
    const real rho0 = setup.materials[pf.material].density;
    const TaitEOS eos(cfg.speed_of_sound, rho0, cfg.eos_gamma);
    for (size_t q = 0; q < pf.lattice.points.size(); ++q) {
      const real p = rho0 * g_mag * pf.lattice.depth[q];
      const real rho = eos.density(p);
      setup.fluid.add(pf.lattice.points[q], rho, rho0 * std::pow(dp, D), pf.material, 0);
    }
  }
  const real bmass = cfg.boundary_density * std::pow(dp, D);
  for (const auto& [p, tag] : bparticles) setup.boundary.add(p, cfg.boundary_density, bmass, 0, tag);
  const long total = static_cast<long>(setup.fluid.size() + setup.boundary.size());
  if (total > scene.max_particles)
    throw SceneError("dp", "the scene has " + std::to_string(total) + " particles, over limits.max_particles = " +
                               std::to_string(scene.max_particles));

  // Domain: default is the bounding box of all particles plus 4h; every face closed.
  Vec<D> lo = Vec<D>::Constant(1e300), hi = Vec<D>::Constant(-1e300);
  for (size_t i = 0; i < setup.fluid.size(); ++i) {
    lo = lo.cwiseMin(setup.fluid.position(i));
    hi = hi.cwiseMax(setup.fluid.position(i));
  }
  for (size_t i = 0; i < setup.boundary.size(); ++i) {
    lo = lo.cwiseMin(setup.boundary.position(i));
    hi = hi.cwiseMax(setup.boundary.position(i));
  }
  for (const auto& in : setup.inlets) {
    // The buffer behind the plane is part of the scene.
    const real back = in.at - in.direction * inlet_buffer_layers(cfg) * dp;
    lo[in.axis] = std::min(lo[in.axis], std::min(back, in.at));
    hi[in.axis] = std::max(hi[in.axis], std::max(back, in.at));
    lo[D - 1] = std::min(lo[D - 1], in.lo[D - 2]);
    hi[D - 1] = std::max(hi[D - 1], in.hi[D - 2]);
  }
  const real margin = 4.0 * cfg.smoothing_length;
  for (int d = 0; d < D; ++d) {
    cfg.domain_min[d] = lo[d] - margin;
    cfg.domain_max[d] = hi[d] + margin;
  }
  if (tmodel) {
    // The corridor's bounding box; faces on the DEM's edge let the flow leave the modelled area. The other
    // faces stand `margin` off the box: flow past them has left the corridor, which the run's terrain check
    // (every 10 steps, well under a margin of travel) removes as corridor outflow rather than a leak.
    cfg.domain_min[0] = 0.0;
    cfg.domain_min[1] = 0.0;
    cfg.domain_max[0] = tmodel->bed.nx * dp;
    cfg.domain_max[1] = tmodel->bed.ny * dp;
    for (int d = 0; d < 2; ++d) {
      cfg.outflow[d] = tmodel->open_faces[d];
      if (!cfg.outflow[d][0]) cfg.domain_min[d] -= margin;
      if (!cfg.outflow[d][1]) cfg.domain_max[d] += margin;
    }
    if (top.has("domain")) throw SceneError("domain", "a terrain scene takes its domain from the corridor");
  }
  if (top.has("domain")) {
    Fields dom(top.raw("domain"), "domain", {"min", "max", "periodic", "outflow"});
    if (dom.has("min")) {
      const auto v = dom.vector("min", D);
      for (int d = 0; d < D; ++d) cfg.domain_min[d] = v[d];
    }
    if (dom.has("max")) {
      const auto v = dom.vector("max", D);
      for (int d = 0; d < D; ++d) {
        cfg.domain_max[d] = v[d];
        if (!(cfg.domain_max[d] > cfg.domain_min[d])) throw SceneError("domain.max", "must exceed domain.min");
      }
    }
    if (dom.has("periodic")) {
      const json& p = dom.raw("periodic");
      if (!p.is_array() || p.size() != static_cast<size_t>(D))
        throw SceneError("domain.periodic", "must be an array of " + std::to_string(D) + " booleans");
      if (p[D - 1].is_boolean() && p[D - 1].get<bool>())
        throw SceneError("domain.periodic", "the vertical axis cannot be periodic (its entry must be false)");
      for (int d = 0; d < D; ++d) {
        if (!p[d].is_boolean()) throw SceneError("domain.periodic", "must be an array of booleans");
        cfg.periodic[d] = p[d].get<bool>();
        if (cfg.periodic[d] && (!dom.has("min") || !dom.has("max")))
          throw SceneError("domain.periodic", "a periodic axis needs domain.min and domain.max");
        if (cfg.periodic[d] && cfg.domain_max[d] - cfg.domain_min[d] < 6.0 * cfg.smoothing_length)
          throw SceneError("domain.periodic", "a periodic axis must be at least 6h long");
      }
    }
    FaceMask<D> outflow = parse_faces<D>(dom, "outflow", FaceMask<D>{});
    for (int d = 0; d < D; ++d) cfg.outflow[d] = outflow[d];
    // Every fluid particle starts inside the domain (above the top is allowed: the top is open).
    for (size_t i = 0; i < setup.fluid.size(); ++i) {
      for (int d = 0; d < D; ++d) {
        const real x = setup.fluid.pos[d][i];
        if (x < cfg.domain_min[d] || (d < D - 1 && x > cfg.domain_max[d])) {
          std::ostringstream s;
          s << "fluid particle at (";
          for (int e = 0; e < D; ++e) s << (e ? ", " : "") << setup.fluid.pos[e][i];
          s << ") m is outside the domain: domain.min and domain.max must contain every particle";
          throw SceneError("domain", s.str());
        }
      }
    }
  }

  // Monitors: gauges and loads by name. On terrain every walled structure gets a load monitor anyway.
  {
    std::set<std::string> names;
    const real ox = tmodel ? tmodel->origin_x : 0.0, oy = tmodel ? tmodel->origin_y : 0.0;
    if (top.has("monitors")) {
      const json& ms = top.raw("monitors");
      if (!ms.is_array()) throw SceneError("monitors", "must be an array of monitors");
      for (size_t k = 0; k < ms.size(); ++k) {
        const std::string path = "monitors[" + std::to_string(k) + "]";
        MonitorSpec spec;
        spec.type = Fields(ms[k], path, {"type", "name", "line", "x", "arrival_volume", "structure", "normal"})
                        .string("type", {"section", "structure_load"});
        std::set<std::string> allowed = {"type", "name"};
        if (spec.type == "section") allowed.insert({D == 3 ? "line" : "x", "arrival_volume"});
        if (spec.type == "structure_load") allowed.insert({"structure", "normal"});
        Fields f(ms[k], path, allowed);
        spec.name = f.string("name");
        if (!names.insert(spec.name).second) throw SceneError(f.at("name"), "duplicate monitor name '" + spec.name + "'");
        if (spec.type == "section") {
          if constexpr (D == 3) {
            for (const auto& p : parse_polyline(f.raw("line"), f.at("line"), 2)) spec.points.push_back({p[0] - ox, p[1] - oy});
          } else {
            spec.points.push_back({f.number("x", -1e7, 1e7), 0.0});
          }
          spec.arrival_volume = f.number_or("arrival_volume", 0.0, 0.0, 1e12);
        } else {
          const std::string target = f.string("structure");
          auto it = std::find(scene.boundary_tags.begin() + 1, scene.boundary_tags.end(), target);
          if (it == scene.boundary_tags.end())
            throw SceneError(f.at("structure"), "no boundary or structure named '" + target + "' (named: " +
                                                    Fields::join({scene.boundary_tags.begin() + 1, scene.boundary_tags.end()}) + ")");
          spec.tag = static_cast<uint32_t>(it - scene.boundary_tags.begin());
          if (f.has("normal")) {
            const auto n = f.vector("normal", D, -1.0, 1.0);
            real n2 = 0;
            for (int d = 0; d < D; ++d) spec.normal[d] = n[d], n2 += n[d] * n[d];
            if (!(n2 > 1e-12)) throw SceneError(f.at("normal"), "must not be zero");
          } else if (tmodel) {
            for (const auto& st : tmodel->structures)
              if (st.name == target) spec.normal = {st.flow_normal[0], st.flow_normal[1], 0.0};
          }
        }
        scene.monitors.push_back(spec);
      }
    }
    if (tmodel) {
      for (const auto& st : tmodel->structures) {
        if (!st.tag) continue;
        bool covered = false;
        for (const auto& m : scene.monitors) covered = covered || (m.type == "structure_load" && m.tag == st.tag);
        if (covered || names.count(st.name)) continue;
        MonitorSpec spec;
        spec.type = "structure_load";
        spec.name = st.name;
        spec.tag = st.tag;
        spec.normal = {st.flow_normal[0], st.flow_normal[1], 0.0};
        scene.monitors.push_back(spec);
      }
    }
  }

  scene.terrain = std::move(tmodel);
  scene.setup = std::move(setup);
  return scene;
}

}  // namespace

Scene parse_scene(const std::string& json_text, const std::filesystem::path& base_dir) {
  json j;
  try {
    j = json::parse(json_text);
  } catch (const json::exception& e) {  // parse_error, and out_of_range for numbers beyond a double (1e400)
    throw SceneError("(json)", std::string("malformed JSON: ") + e.what());
  }
  if (!j.is_object()) throw SceneError("(root)", "a scene must be a JSON object");
  Fields top(j, "", std::set<std::string>(kTopKeys.begin(), kTopKeys.end()));
  Scene scene;
  scene.name = top.string_or("name", "scene");
  (void)top.string_or("description", "");
  scene.dimensions = static_cast<int>(top.integer("dimensions", 0, 2, 3));
  if (!top.has("dimensions")) throw SceneError("dimensions", "missing (required: 2 or 3)");
  scene.dp = top.number("dp", 1e-4, 100.0);
  if (top.has("fidelity")) {  // presets used by sweeps (scenarios/sweep.hpp); a plain run is "standard"
    Fields fid(top.raw("fidelity"), "fidelity", {"draft", "standard", "fine"});
    for (const char* level : {"draft", "standard", "fine"}) {
      if (!fid.has(level)) continue;
      Fields p(fid.raw(level), fid.at(level), {"dp", "numerics"});
      (void)p.number_or("dp", scene.dp, 1e-4, 100.0);
      if (p.has("numerics") && !p.raw("numerics").is_object())
        throw SceneError(p.at("numerics"), "must be an object of numerics fields");
    }
  }
  scene.duration = top.number("duration", 0.0, 1e5, true);
  Fields out(j.contains("output") ? j["output"] : json::object(), "output", {"series_interval", "snapshot_interval", "inundation_threshold"});
  scene.output.series_interval = out.number_or("series_interval", std::min(0.01, scene.duration / 100.0), 0.0, 1e4, true);
  scene.output.snapshot_interval = out.number_or("snapshot_interval", 0.0, 0.0, 1e4);
  scene.output.inundation_threshold = out.number_or("inundation_threshold", 0.1, 0.0, 100.0, true);
  scene.canonical_json = j.dump();
  return scene.dimensions == 2 ? build<2>(j, std::move(scene), base_dir) : build<3>(j, std::move(scene), base_dir);
}

Scene load_scene(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw SceneError("(file)", "cannot read scene file '" + path.string() + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene(ss.str(), path.parent_path());
}

}  // namespace runout
