// The scene schema and the docs' parameter tables come from the models' descriptors, and stay in step with them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/schema.hpp"

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
