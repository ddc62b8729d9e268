// The scene schema and the docs' parameter tables come from the models' descriptors, and stay in step with them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <map>
#include <set>
#include <sstream>

#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/schema.hpp"
#include "runout/engine/monitors.hpp"
#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

using json = nlohmann::json;
using namespace runout;

namespace {
const std::string kBegin = "<!-- material-parameters:begin -->\n", kEnd = "<!-- material-parameters:end -->";
const std::string kDoc = std::string(RUNOUT_SOURCE_DIR) + "/docs/scene-format.md";

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(Schema, DocsParameterTablesMatchTheDescriptors) {
  std::string doc = read(kDoc);
  const auto b = doc.find(kBegin), e = doc.find(kEnd);
  ASSERT_NE(b, std::string::npos) << kDoc << " lost its " << kBegin;
  ASSERT_NE(e, std::string::npos);
  const std::string have = doc.substr(b + kBegin.size(), e - b - kBegin.size());
  const std::string want = material_parameter_tables();
  if (have != want && std::getenv("RUNOUT_REGENERATE_DOCS")) {
    doc.replace(b + kBegin.size(), e - b - kBegin.size(), want);
    std::ofstream(kDoc) << doc;
    GTEST_SKIP() << "rewrote the parameter tables of " << kDoc;
  }
  EXPECT_EQ(have, want) << kDoc << " differs from the descriptors: RUNOUT_REGENERATE_DOCS=1 " 
                        << "build/tests/scenarios_schema_test rewrites it";
}

TEST(Schema, EveryRheologyIsAnAlternativeWithItsParameters) {
  const json s = scene_schema();
  const json& alts = s.at("properties").at("materials").at("items").at("oneOf");
  ASSERT_EQ(alts.size(), rheology_models().size());
  for (size_t k = 0; k < alts.size(); ++k) {
    const RheologyModel& m = *rheology_models()[k];
    EXPECT_EQ(alts[k]["properties"]["rheology"]["const"], m.name);
    EXPECT_FALSE(alts[k]["additionalProperties"].get<bool>());
    for (const auto& p : m.parameters) {
      const json& q = alts[k]["properties"].at(p.key);
      EXPECT_EQ(q.contains("default"), !p.required) << m.name << "." << p.key;
      const bool listed = std::find(alts[k]["required"].begin(), alts[k]["required"].end(), p.key) != alts[k]["required"].end();
      EXPECT_EQ(listed, p.required) << m.name << "." << p.key;
    }
  }
}

// What the schema says of a parameter's range, the parser enforces: the end of each declared range is
// accepted when closed and refused when open, and just outside it is refused, naming the field.
TEST(Schema, ParserEnforcesTheDescribedRanges) {
  auto scene_with = [](const json& material) {
    return json{{"dimensions", 2}, {"dp", 0.01}, {"duration", 0.01}, {"materials", {material}},
                {"fluid", {{{"min", {0, 0}}, {"max", {0.05, 0.05}}, {"material", "m"}}}}}
        .dump();
  };
  for (const auto* m : rheology_models()) {
    json base = {{"name", "m"}, {"rheology", m->name}, {"density", 1500}};
    for (const auto& p : m->parameters)
      if (p.required) base[p.key] = p.key == "mu_2" ? 0.6 : (p.key == "mu_s" ? 0.4 : std::max(p.lo, 0.0) + 1e-3);
    ASSERT_NO_THROW(parse_scene(scene_with(base))) << m->name;
    for (const auto& p : m->parameters) {
      if (!std::isfinite(p.hi) || p.key == "mu_s" || p.key == "mu_2") continue;
      json over = base;
      over[p.key] = p.hi * 1.5 + 1;
      try {
        parse_scene(scene_with(over));
        ADD_FAILURE() << m->name << "." << p.key << " accepted above its range";
      } catch (const SceneError& e) {
        EXPECT_EQ(e.field, "materials[0]." + p.key) << e.what();
      }
    }
    json unknown = base;
    unknown["not_a_parameter"] = 1;
    EXPECT_THROW(parse_scene(scene_with(unknown)), SceneError) << m->name;
  }
}

// docs/scene-format.md's numerics table is hand-written (its computed defaults need prose): each plain-number
// row must still state its descriptor's default and accepted range.
TEST(Schema, DocsNumericsTableAgreesWithTheDescriptors) {
  const std::string doc = read(kDoc);
  for (const auto& p : numerics_parameters()) {
    const std::string head = "| `" + p.key + "` |";
    const auto at = doc.find(head);
    ASSERT_NE(at, std::string::npos) << "docs/scene-format.md has no row for numerics." << p.key;
    const std::string row = doc.substr(at, doc.find('\n', at) - at);
    const std::string range = std::string(p.lo_open ? "(" : "[") + format_number(p.lo) + ", " + format_number(p.hi) +
                              (p.hi_open ? ")" : "]");
    EXPECT_NE(row.find("`" + format_number(p.default_value) + "`"), std::string::npos) << p.key << " default: " << row;
    EXPECT_NE(row.find(range), std::string::npos) << p.key << " range " << range << ": " << row;
  }
}

// A SolverConfig made in code (an engine test, a bench) starts from the numerics a scene gets when it says nothing:
// one source (numerics_default, solver.hpp). The smoothing length was 1.3 dp in the engine and 1.5 dp in scenes.
TEST(Schema, SolverConfigStartsFromTheScenesNumericsDefaults) {
  const SolverConfig c;
  const auto def = [](const char* key) { return numerics_parameter(key).default_value; };
  EXPECT_DOUBLE_EQ(c.smoothing_length / c.dp, def("smoothing_ratio"));
  EXPECT_EQ(c.verlet_reset_steps, def("verlet_reset_steps"));
  EXPECT_EQ(c.cfl, def("cfl"));
  EXPECT_EQ(c.density_diffusion_delta, def("density_diffusion_delta"));
  EXPECT_EQ(c.artificial_viscosity, def("artificial_viscosity"));
  EXPECT_EQ(c.viscosity_cap_factor, def("viscosity_cap_factor"));
  EXPECT_EQ(c.viscous_tolerance, def("viscous_tolerance"));
  EXPECT_EQ(c.viscous_max_iterations, def("viscous_max_iterations"));
  EXPECT_EQ(c.shear_rate_floor, def("shear_rate_floor"));
  EXPECT_EQ(c.min_dt, def("min_dt"));
  EXPECT_EQ(c.max_dilatancy, def("max_dilatancy"));
  EXPECT_EQ(c.neighbour_skin, def("neighbour_skin"));
  EXPECT_EQ(c.shifting_coefficient, def("shifting_coefficient"));
  // The choices: a scene's defaults are the first of each list (fourtakas the last of density diffusion's).
  EXPECT_EQ(std::string(kernel_name(c.kernel)), kernel_names().front());
  EXPECT_EQ(integrator_names()[static_cast<size_t>(c.integrator)], integrator_names().front());
  EXPECT_EQ(density_diffusion_names()[static_cast<size_t>(c.density_diffusion)], density_diffusion_names().back());
  EXPECT_EQ(particle_shifting_names()[static_cast<size_t>(c.particle_shifting)], particle_shifting_names().front());
}

// The monitors' and structures' tables of docs/scene-format.md are generated from their descriptors.
namespace {
void check_generated_block(const std::string& marker, const std::string& want) {
  const std::string begin = "<!-- " + marker + ":begin -->\n", end = "<!-- " + marker + ":end -->";
  std::string doc = read(kDoc);
  const auto b = doc.find(begin), e = doc.find(end);
  ASSERT_NE(b, std::string::npos) << kDoc << " lost its " << begin;
  ASSERT_NE(e, std::string::npos);
  const std::string have = doc.substr(b + begin.size(), e - b - begin.size());
  if (have != want && std::getenv("RUNOUT_REGENERATE_DOCS")) {
    doc.replace(b + begin.size(), e - b - begin.size(), want);
    std::ofstream(kDoc) << doc;
    GTEST_SKIP() << "rewrote the " << marker << " tables of " << kDoc;
  }
  EXPECT_EQ(have, want) << kDoc << " differs from the descriptors: RUNOUT_REGENERATE_DOCS=1 "
                        << "build/tests/scenarios_schema_test rewrites it";
}
}  // namespace

TEST(Schema, DocsMonitorTablesMatchTheDescriptors) { check_generated_block("monitor-types", monitor_type_tables()); }

TEST(Schema, DocsBoundaryTablesMatchTheDescriptors) { check_generated_block("boundary-types", boundary_type_tables()); }
TEST(Schema, DocsOutputTableMatchesTheDescriptors) { check_generated_block("output-fields", output_field_table()); }
TEST(Schema, DocsTerrainTablesMatchTheDescriptors) { check_generated_block("terrain-fields", terrain_field_tables()); }
TEST(Schema, DocsStructureTablesMatchTheDescriptors) {
  check_generated_block("structure-types", structure_type_tables());
}

// Every monitor and structure type is an alternative of its section, with its declared keys and nothing else.
TEST(Schema, EveryMonitorAndStructureTypeIsAnAlternativeWithItsKeys) {
  const json s = scene_schema();
  auto check = [](const json& alts, const std::string& name, const std::vector<FieldSpec>& fields) {
    for (const auto& alt : alts) {
      if (alt["properties"]["type"]["const"] != name) continue;
      EXPECT_FALSE(alt["additionalProperties"].get<bool>()) << name;
      EXPECT_EQ(alt["properties"].size(), fields.size() + 2) << name;
      for (const auto& f : fields) EXPECT_TRUE(alt["properties"].contains(f.key)) << name << "." << f.key;
      return;
    }
    ADD_FAILURE() << "no schema alternative for " << name;
  };
  for (const auto* t : monitor_types())
    check(s["properties"]["monitors"]["items"]["oneOf"], t->name, t->fields);
  for (const auto* t : terrain::structure_types())
    check(s["properties"]["structures"]["items"]["oneOf"], t->name, t->fields);
}

// Every boundary type is an alternative of `boundaries` with its own keys and those every boundary has
// (type, tag, layers), and no name: the four types docs/scene-format.md describes.
TEST(Schema, EveryBoundaryTypeIsAnAlternativeWithItsKeys) {
  const json alts = scene_schema()["properties"]["boundaries"]["items"]["oneOf"];
  const std::map<std::string, std::set<std::string>> want = {
      {"tank", {"min", "max", "origin", "size", "angle", "open"}},
      {"block", {"min", "max", "origin", "size", "angle"}},
      {"plane", {"origin", "length", "angle", "width"}},
      {"flume", {"origin", "length", "angle", "width", "wall_height"}}};
  ASSERT_EQ(alts.size(), want.size());
  for (const auto& alt : alts) {
    const std::string name = alt["properties"]["type"]["const"];
    ASSERT_TRUE(want.count(name)) << name;
    std::set<std::string> keys = want.at(name);
    keys.insert({"type", "tag", "layers"});
    std::set<std::string> have;
    for (auto it = alt["properties"].begin(); it != alt["properties"].end(); ++it) have.insert(it.key());
    EXPECT_EQ(have, keys) << name;
    EXPECT_FALSE(alt["additionalProperties"].get<bool>()) << name;
  }
}

// What a structure's descriptor says of a number's range, the parser enforces (naming the field and the range).
TEST(Schema, ParserEnforcesTheStructureRanges) {
  for (const auto* t : terrain::structure_types()) {
    for (const auto& f : t->fields) {
      if (f.shape != "number") continue;
      const ParameterSpec& p = f.parameters.front();
      json st = {{"type", t->name}, {"name", "s"}, {f.key, p.hi + 1}};
      const json scene = {{"dimensions", 3}, {"dp", 1}, {"duration", 1}, {"terrain", {{"dem", "none.tif"}}},
                          {"materials", {{{"name", "m"}, {"rheology", "newtonian"}, {"density", 1000}}}},
                          {"release", {{"polygon", {{0, 0}, {1, 0}, {1, 1}}}, {"depth", 1}, {"material", "m"}}},
                          {"structures", {st}}};
      // The geometry key comes first in every type; give it so the number is what the parser refuses.
      json with_geometry = scene;
      const FieldSpec& g = t->fields.front();
      with_geometry["structures"][0][g.key] = json::array({{0, 0}, {1, 0}, {1, 1}});
      for (const auto& other : t->fields)
        if (other.required && other.shape == "number" && other.key != f.key)
          with_geometry["structures"][0][other.key] = other.parameters.front().hi;
      if (t->name == "retention_basin")
        for (const char* k : {"depth", "wall_height"})
          if (f.key != k) with_geometry["structures"][0][k] = 1;
      try {
        parse_scene(with_geometry.dump());
        ADD_FAILURE() << t->name << "." << f.key << " accepted above its range";
      } catch (const SceneError& e) {
        EXPECT_EQ(e.field, "structures[0]." + f.key) << e.what();
        EXPECT_NE(std::string(e.what()).find("must be a number in"), std::string::npos) << e.what();
      }
    }
  }
}

// The rules across a structure's keys (its type's `check`) are refused naming the key at fault.
TEST(Schema, StructureRulesAcrossKeysNameTheKey) {
  auto refusal = [](const json& st) -> std::pair<std::string, std::string> {
    const json scene = {{"dimensions", 3}, {"dp", 1}, {"duration", 1}, {"terrain", {{"dem", "none.tif"}}},
                        {"materials", {{{"name", "m"}, {"rheology", "newtonian"}, {"density", 1000}}}},
                        {"release", {{"polygon", {{0, 0}, {1, 0}, {1, 1}}}, {"depth", 1}, {"material", "m"}}},
                        {"structures", {st}}};
    try {
      parse_scene(scene.dump());
    } catch (const SceneError& e) {
      return {e.field, e.what()};
    }
    return {"accepted", ""};
  };
  const json axis = json::array({{0, 0}, {10, 0}});
  const json square = json::array({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
  auto [f1, m1] = refusal({{"type", "check_dam"}, {"name", "d"}, {"axis", axis}, {"crest_height", 2},
                           {"thickness", 1}, {"slit", {{"width", 1}, {"bottom", 2}}}});
  EXPECT_EQ(f1, "structures[0].slit.bottom");
  EXPECT_NE(m1.find("must be below crest_height (2 m)"), std::string::npos) << m1;
  auto [f2, m2] = refusal({{"type", "retention_basin"}, {"name", "b"}, {"polygon", square}});
  EXPECT_EQ(f2, "structures[0]");
  EXPECT_NE(m2.find("needs depth > 0 m or wall_height > 0 m"), std::string::npos) << m2;
  auto [f3, m3] = refusal({{"type", "retention_basin"}, {"name", "b"}, {"polygon", square}, {"wall_height", 2}});
  EXPECT_EQ(f3, "structures[0].wall_thickness");
  EXPECT_NE(m3.find("missing"), std::string::npos) << m3;
  EXPECT_NE(m3.find("(0, 100]"), std::string::npos) << m3;
  auto [f4, m4] = refusal({{"type", "retention_basin"}, {"name", "b"}, {"polygon", square}, {"depth", 1},
                           {"open_edges", {4}}});
  EXPECT_EQ(f4, "structures[0].open_edges[0]");
  EXPECT_NE(m4.find("[0, 3]"), std::string::npos) << m4;
}

// The numerics rows whose defaults the scene computes state their declared ranges too.
TEST(Schema, DocsNumericsTableAgreesWithTheSceneDescriptors) {
  const std::string doc = read(kDoc);
  for (const auto& f : scene_numerics_fields()) {
    const ParameterSpec& p = f.parameters.front();
    const auto at = doc.find("| `" + f.key + "` |");
    ASSERT_NE(at, std::string::npos) << "docs/scene-format.md has no row for numerics." << f.key;
    const std::string row = doc.substr(at, doc.find('\n', at) - at);
    const std::string range = std::string(p.lo_open ? "(" : "[") + format_number(p.lo) + ", " + format_number(p.hi) +
                              (p.hi_open ? ")" : "]");
    EXPECT_NE(row.find(range), std::string::npos) << f.key << " range " << range << ": " << row;
  }
}

// The terrain scene's sections are described by their descriptors too: the schema lists their keys with the
// declared ranges, and the parser refuses just past each declared end (on the flume's scene), naming the field.
TEST(Schema, TerrainSectionsEnforceTheirDescribedRanges) {
  const std::string dir = std::string(RUNOUT_SOURCE_DIR) + "/scenarios/flume";
  const json flume = json::parse(read(dir + "/flume.json"));
  const json s = scene_schema();
  EXPECT_FALSE(s["properties"]["terrain"]["additionalProperties"].get<bool>());
  EXPECT_EQ(s["properties"]["terrain"]["properties"]["walls"]["enum"], json({"near_flow", "all"}));
  EXPECT_EQ(s["properties"]["release"]["properties"]["hydrograph"]["properties"]["depth"]["maximum"], 1000);
  int refused = 0;
  for (const std::string section : {"terrain", "terrain.corridor", "release"}) {
    const json& props = section == "terrain.corridor" ? s["properties"]["terrain"]["properties"]["corridor"]["properties"]
                                                      : s["properties"][section]["properties"];
    for (const auto& [key, field] : props.items()) {
      if (!field.contains("maximum")) continue;
      json scene = flume;
      json& target = section == "terrain.corridor" ? scene["terrain"]["corridor"] : scene[section];
      if (section == "release") target.erase(key == "depth" ? "volume" : "depth");  // one of the two
      target[key] = field["maximum"].get<double>() * 1.5 + 1;
      try {
        (void)parse_scene(scene.dump(), dir);
        ADD_FAILURE() << section << "." << key << " accepted above its range";
      } catch (const SceneError& e) {
        EXPECT_EQ(e.field, section + "." + key) << e.what();
        ++refused;
      }
    }
  }
  EXPECT_EQ(refused, 7);  // resolution, layers; travel_angle, buffer, max_outflow; depth, volume
}

// A numerics or monitor field out of its declared range is refused before the terrain is built: the DEM is not
// even read (what a refused request to the service then costs: docs/performance.md, "Estimates").
TEST(Schema, DeclaredFieldsAreRefusedBeforeTheTerrainIsBuilt) {
  const std::string dir = std::string(RUNOUT_SOURCE_DIR) + "/scenarios/flume";
  const json flume = json::parse(read(dir + "/flume.json"));
  json bad_numerics = flume, bad_monitor = flume, bad_kernel = flume;
  bad_numerics["numerics"]["cfl"] = 7;
  bad_kernel["numerics"]["kernel"] = "gauss";
  bad_monitor["monitors"] = {{{"type", "section"}, {"name", "S"}, {"line", {{500003.0, 5000000.0}, {500003.0, 5000001.2}}},
                              {"window", -1}}};
  const std::pair<const json*, std::string> cases[] = {
      {&bad_numerics, "numerics.cfl"}, {&bad_kernel, "numerics.kernel"}, {&bad_monitor, "monitors[0].window"}};
  for (const auto& [scene, field] : cases) {
    const terrain::DemCacheStats before = terrain::dem_cache_stats();
    try {
      (void)parse_scene(scene->dump(), dir);
      ADD_FAILURE() << field << " accepted";
    } catch (const SceneError& e) {
      EXPECT_EQ(e.field, field) << e.what();
    }
    const terrain::DemCacheStats after = terrain::dem_cache_stats();
    EXPECT_EQ(after.hits + after.misses, before.hits + before.misses) << field << ": the DEM was read";
  }
  const terrain::DemCacheStats before = terrain::dem_cache_stats();
  json plain = flume;
  plain.erase("structures");  // the candidates overlap: a layout holds some of them
  (void)parse_scene(plain.dump(), dir);  // the control: a scene that is built reads its DEM
  const terrain::DemCacheStats after = terrain::dem_cache_stats();
  EXPECT_EQ(after.hits + after.misses, before.hits + before.misses + 1);
}

namespace {

// The fields a scene's refusal lists, in order (none if it is accepted).
std::vector<std::string> refused_fields(const json& scene) {
  std::vector<std::string> fields;
  try {
    (void)parse_scene(scene.dump());
  } catch (const SceneError& e) {
    for (const auto& [field, message] : e.errors) fields.push_back(field);
  }
  return fields;
}

json dam_break_2d() {
  return json::parse(read(std::string(RUNOUT_SOURCE_DIR) + "/scenarios/validation/dam_break_2d.json"));
}

}  // namespace

// The materials' and boundaries' declared fields are checked each on its own as well: one refusal lists a
// density out of range, a rheology parameter out of range, an unknown key, a duplicate material name and a
// boundary's layers out of range and unknown type, in the scene's order.
TEST(Schema, MaterialsAndBoundariesListEveryErrorAtOnce) {
  json scene = dam_break_2d();
  scene["materials"][0]["density"] = -5;
  scene["materials"][0]["viscosity"] = -1;
  scene["materials"][0]["colour"] = "brown";
  scene["materials"].push_back({{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}});
  scene["boundaries"][0]["layers"] = 0;
  scene["boundaries"].push_back({{"type", "moat"}});
  EXPECT_EQ(refused_fields(scene), (std::vector<std::string>{"materials[0].colour", "materials[0].density",
                                                             "materials[0].viscosity", "materials[1].name",
                                                             "boundaries[0].layers", "boundaries[1].type"}));
}

// The top level too, and the sections whose keys are plain lists: an unknown key at the top, in a fluid block
// and in the limits, dp and duration out of range and a numerics error, in one refusal.
TEST(Schema, TheTopLevelAndTheListedSectionsListEveryErrorAtOnce) {
  json scene = dam_break_2d();
  scene["colour"] = "brown";
  scene["dp"] = 0;
  scene["duration"] = 0;
  scene["fluid"][0]["colour"] = "brown";
  scene["limits"] = {{"max_particle", 10}};
  scene["numerics"]["cfl"] = 7;
  EXPECT_EQ(refused_fields(scene), (std::vector<std::string>{"colour", "dp", "duration", "fluid[0].colour",
                                                             "limits.max_particle", "numerics.cfl"}));
}
