#pragma once
// The scene parser's private pieces: `Fields` reads one JSON object (unknown keys and out-of-range values
// refused with the field's path), and one reader per section of a scene fills a `Build<D>` in the order
// build<D> (scene.cpp) calls them. docs/scene-format.md describes every section.
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/engine/geometry.hpp"
#include "runout/engine/parameters.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/terrain.hpp"
#include "runout/terrain/vector.hpp"

namespace runout::scene_reader {

using json = nlohmann::json;

inline std::string fmt(real v) {
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

// A declared number read from f: its key, default and range from its descriptor (integers as integers).
inline real read_parameter(const Fields& f, const ParameterSpec& p) {
  if (p.integer)
    return static_cast<real>(f.integer(p.key, static_cast<long>(p.default_value), static_cast<long>(p.lo),
                                       static_cast<long>(p.hi)));
  if (p.required) return f.number(p.key, p.lo, p.hi, p.lo_open, p.hi_open);
  return f.number_or(p.key, p.default_value, p.lo, p.hi, p.lo_open, p.hi_open);
}

template <int D>
Vec<D> to_vec(const std::vector<real>& v) {
  Vec<D> out;
  for (int d = 0; d < D; ++d) out[d] = v[d];
  return out;
}

// Face names: x-, x+, y-, y+, (z-, z+), and "top"/"bottom" for the vertical axis.
template <int D>
FaceMask<D> parse_faces(const Fields& f, const std::string& key, FaceMask<D> mask);

// A box: either {min, max} (axis-aligned) or {origin, size, angle}.
template <int D>
OrientedBox<D> parse_box(const Fields& f);

// A polyline or polygon: an array of [x, y] map coordinates.
terrain::Polyline parse_polyline(const json& v, const std::string& field, size_t min_points);

// Where a layer reference's file and CRS come from: the scene's folder and the working CRS (the DEM's, asked
// only when a layer is read; unset where the scene has no terrain).
struct ShapeSource {
  std::filesystem::path base_dir;
  std::function<std::string()> working_crs;
};
// A line or polygon in map coordinates: an array of [x, y] points (parse_polyline), or a layer reference
// {"layer": FILE, "name": LAYER, "where": FILTER, "crs": CRS} read through terrain's read_vector_shape
// (docs/scene-format.md, "Geometry from vector files"). Errors name `field`.
terrain::Polyline read_shape(const json& v, const std::string& field, size_t min_points, terrain::ShapeKind kind,
                             const ShapeSource& source);

// The output section's keys (output.cpp), and the section read with them.
const std::vector<FieldSpec>& output_fields();
OutputSettings read_output(const json& j, real duration);

// "name[k]" for an element of an array section.
inline std::string item(const std::string& section, size_t k) { return section + "[" + std::to_string(k) + "]"; }

enum class Make { particles, counts, nothing };

// What the section readers share while they build one scene.
template <int D>
struct Build {
  struct PendingFluid {
    Lattice<D> lattice;
    uint16_t material;
  };
  Build(const json& scene_json, Scene& s, const std::filesystem::path& dir);

  const json& j;
  const Fields top;
  Scene& scene;
  std::filesystem::path base_dir;
  SceneSetup<D> setup;
  SolverConfig& cfg;
  real dp;
  real g_mag = 0;
  std::map<std::string, uint16_t> material_index;
  std::shared_ptr<terrain::TerrainModel> tmodel;
  std::string release_material;
  std::vector<PendingFluid> pending;        // fluid lattices, made into particles once c0 is known
  real fluid_top = -1e300, fluid_bottom = 1e300;
  real inlet_speed_max = 0;
  std::vector<std::pair<Vec<D>, uint32_t>> bparticles;  // boundary particles and their tags
  // Terrain: the bed's particles, laid near the flow by the solver (terrain.walls = "near_flow") or all at
  // the start after the other boundary particles ("all").
  std::shared_ptr<const WallSource<3>> bed_source;
  bool walls_near_flow = true;
  // What the build does with the 3D particles: make them (a run), count them only (an estimate: no particle
  // arrays, no bed laid), or neither (the screening model runs the scene and makes its own; no bed source).
  Make make = Make::particles;
  real bottom = 0;                                       // the lowest particle (after the boundaries)
  // The box of every particle the scene starts with (fluid, walls, the bed laid whole, the lowest bed particle
  // when it is laid near the flow), made or counted: the default domain's.
  Vec<D> lo = Vec<D>::Constant(1e300), hi = Vec<D>::Constant(-1e300);
};

// The sections, in the order build<D> reads them (each refuses what it cannot use, naming the field).
template <int D> void read_gravity(Build<D>& b);
template <int D> void read_materials(Build<D>& b);
template <int D> void read_limits(Build<D>& b);
template <int D> void read_terrain(Build<D>& b);
template <int D> void read_fluid(Build<D>& b);
template <int D> void read_inlets(Build<D>& b);
template <int D> void read_boundaries(Build<D>& b);
template <int D> void check_fluid_placement(const Build<D>& b);
template <int D> void read_numerics(Build<D>& b);
template <int D> void make_particles(Build<D>& b);
template <int D> void read_domain(Build<D>& b);
template <int D> void read_monitors(Build<D>& b);

// The declared fields of the output, numerics, monitors and terrain sections, each key checked on its own before
// anything is built (declared.cpp): throws one SceneError listing every error (SceneError::errors), so a refusal
// names them all and costs no terrain build. The section readers read the same keys again when building.
void check_declared_fields(const json& j, int dimensions);
// The keys a monitor of `types` accepts in a scene of dimension D (0: whatever the dimension).
std::set<std::string> monitor_keys(const std::vector<const MonitorType*>& types, int D);

// The terrain, release, structures and protected_zones sections (docs/scene-format.md, "Terrain scenes"): their
// keys (terrain_fields.cpp), for the readers, the schema and the docs.
const std::vector<FieldSpec>& terrain_fields();         // terrain
const std::vector<FieldSpec>& corridor_fields();        // terrain.corridor
const std::vector<FieldSpec>& release_fields();         // release
const std::vector<FieldSpec>& hydrograph_fields();      // release.hydrograph
const std::vector<FieldSpec>& protected_zone_fields();  // protected_zones[k]
const std::vector<std::string>& terrain_wall_choices(); // terrain.walls
std::set<std::string> field_keys(const std::vector<FieldSpec>& fields);
// A hydrograph release's strip behind its line, in dp: it holds the inlet's buffer (ceil(2h/dp) + 1 layers,
// at most 8 for the accepted smoothing ratios) and is what the floor under each lane is fitted over.
constexpr int kInflowStripLayers = 8;
terrain::TerrainSpec parse_terrain_spec(const json& j, const std::filesystem::path& base_dir);

// The top-level keys of a scene.
const std::set<std::string>& top_keys();
// The top level's declared numbers (dp, duration): read by parse_scene, checked by check_declared_fields.
const std::vector<FieldSpec>& top_fields();
// The keys of a fluid block, an inlet, the domain and the limits, for their readers and check_declared_fields.
const std::set<std::string>& fluid_block_keys();
const std::set<std::string>& inlet_keys();
const std::set<std::string>& domain_keys();
const std::set<std::string>& limits_keys();

}  // namespace runout::scene_reader
