// Sweeps: the study's factorial numbering, variant resolution (structures kept, fidelity applied),
// manifests that identify a run, and refused sweep files.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

std::string names(const SweepVariant& v) {
  std::string s;
  for (const auto& n : v.structures) s += (s.empty() ? "" : "+") + n;
  return s.empty() ? "none" : s;
}

// A terrain-free base scene with "structures" is not valid (they need terrain), so the sweep tests use the
// real terrain example with candidate structures added.
json base_scene() {
  std::ifstream in(fs::path(RUNOUT_SOURCE_DIR) / "scenarios/terrain/jacksboro_slope.json");
  json j = json::parse(in);
  j["terrain"]["dem"] = (fs::path(RUNOUT_SOURCE_DIR) / "scenarios/dem/jacksboro_fault_dem.vrt").string();
  j["structures"] = json::parse(R"([
    {"type": "check_dam", "name": "Dam1", "axis": [[739080, 4045000], [739080, 4045090]], "crest_height": 3, "thickness": 3},
    {"type": "check_dam", "name": "Dam2", "axis": [[739140, 4044950], [739180, 4045100]], "crest_height": 3, "thickness": 3},
    {"type": "deposition_area", "name": "Flat", "polygon": [[739200, 4044900], [739260, 4044900], [739260, 4044960], [739200, 4044960]]}
  ])");
  j["monitors"] = json::parse(R"([{"type": "structure_load", "name": "Dam1 load", "structure": "Dam1"}])");
  j["fidelity"] = json::parse(R"({"draft": {"dp": 2.0, "numerics": {"cfl": 0.25}}})");
  return j;
}

struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("runout-sweep-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
};

}  // namespace

TEST(Sweep, FactorialIsNumberedAsInTheStudy) {
  const auto v = factorial_variants({"Dam1", "Dam2", "Dam3"}, "G");
  ASSERT_EQ(v.size(), 8u);
  const std::vector<std::string> expected = {"none",      "Dam1",      "Dam2",      "Dam3",
                                             "Dam1+Dam2", "Dam1+Dam3", "Dam2+Dam3", "Dam1+Dam2+Dam3"};
  for (size_t k = 0; k < 8; ++k) {
    EXPECT_EQ(v[k].name, "G" + std::to_string(k));
    EXPECT_EQ(names(v[k]), expected[k]);
  }
  EXPECT_EQ(factorial_variants({"A", "B", "C", "D"}, "X").size(), 16u);
}

TEST(Sweep, VariantKeepsItsStructuresAndTakesTheFidelity) {
  const json base = base_scene();
  const std::string resolved = resolve_variant(base.dump(), {"G2", {"Dam2"}}, Fidelity{"draft", {}});
  const json r = json::parse(resolved);
  ASSERT_EQ(r["structures"].size(), 1u);
  EXPECT_EQ(r["structures"][0]["name"], "Dam2");
  EXPECT_EQ(r["monitors"].size(), 0u);  // the load monitor of Dam1, not built here, goes
  EXPECT_DOUBLE_EQ(r["dp"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(r["numerics"]["cfl"].get<double>(), 0.25);
  EXPECT_FALSE(r.contains("fidelity"));
  EXPECT_EQ(r["name"], "jacksboro-slope/G2");
  // Without a preset: fine halves the scene's dp; an explicit dp wins.
  EXPECT_DOUBLE_EQ(json::parse(resolve_variant(base.dump(), {"G0", {}}, Fidelity{"fine", {}}))["dp"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(json::parse(resolve_variant(base.dump(), {"G0", {}}, Fidelity{"custom", 0.8}))["dp"].get<double>(), 0.8);
  // The resolved scene parses, with Dam2's wall tagged and load-monitored.
  const Scene s = parse_scene(resolved);
  ASSERT_EQ(s.monitors.size(), 1u);
  EXPECT_EQ(s.monitors[0].name, "Dam2");
}

TEST(Sweep, ASceneResolvesAtAFidelityAsAVariantDoesButKeepsItsStructuresAndName) {
  const json base = base_scene();
  const json r = json::parse(resolve_scene(base.dump(), Fidelity{"draft", {}}));
  EXPECT_EQ(r["structures"].size(), 3u);  // all of them, as written
  EXPECT_EQ(r["monitors"].size(), 1u);
  EXPECT_EQ(r["name"], base["name"]);
  EXPECT_DOUBLE_EQ(r["dp"].get<double>(), 2.0);                 // the scene's draft preset
  EXPECT_DOUBLE_EQ(r["numerics"]["cfl"].get<double>(), 0.25);  // and its numerics
  EXPECT_FALSE(r.contains("fidelity"));
  // The same resolution as a layout with every structure built (only the name differs).
  json v = json::parse(resolve_variant(base.dump(), {"all", {"Dam1", "Dam2", "Flat"}}, Fidelity{"draft", {}}));
  v["name"] = r["name"];
  EXPECT_EQ(v, r);
  EXPECT_DOUBLE_EQ(json::parse(resolve_scene(base.dump(), Fidelity{"custom", 0.8}))["dp"].get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(json::parse(resolve_scene(base.dump(), Fidelity{"fine", {}}))["dp"].get<double>(), 0.5);
  EXPECT_THROW(resolve_scene("{\"dp\": 1,", Fidelity{}), SceneError);
}

TEST(Sweep, ManifestChangesWithWhatChangesTheRunAndOnlyThat) {
  const json base = base_scene();
  const std::string a = resolve_variant(base.dump(), {"G1", {"Dam1"}}, Fidelity{"draft", {}});
  const std::string b = resolve_variant(base.dump(), {"G2", {"Dam2"}}, Fidelity{"draft", {}});
  const Manifest ma = make_manifest(a, {}, Fidelity{"draft", {}});
  EXPECT_EQ(ma.hash.size(), 64u);
  EXPECT_EQ(ma.hash, make_manifest(json::parse(a).dump(2), {}, Fidelity{"draft", {}}).hash);  // formatting
  EXPECT_NE(ma.hash, make_manifest(b, {}, Fidelity{"draft", {}}).hash);
  EXPECT_NE(ma.hash, make_manifest(a, {}, Fidelity{"fine", {}}).hash);
  EXPECT_NE(json::parse(ma.json)["dem_sha256"].get<std::string>(), "missing");
  json described = json::parse(a);  // a scene's description is prose: rewording it is not a new run
  described["description"] = "the same layout, described again";
  EXPECT_EQ(ma.hash, make_manifest(described.dump(), {}, Fidelity{"draft", {}}).hash);
}

TEST(Sweep, BadSweepFilesAreRefusedNamingTheField) {
  TempDir tmp;
  {
    std::ofstream(tmp.path / "base.json") << base_scene().dump();
  }
  auto field_of = [&](const std::string& text) -> std::string {
    try {
      parse_sweep(text, tmp.path);
    } catch (const SceneError& e) {
      return e.field;
    }
    return "accepted";
  };
  EXPECT_EQ(field_of(R"({"base": "base.json", "factorial": {"structures": ["Dam1", "Dam2"]}})"), "accepted");
  EXPECT_EQ(field_of(R"({"base": "missing.json", "variants": [{"name": "A"}]})"), "base");
  EXPECT_EQ(field_of(R"({"base": "base.json"})"), "variants");
  EXPECT_EQ(field_of(R"({"base": "base.json", "variants": [{"name": "A", "structures": ["Dam9"]}]})"),
            "variants[0].structures");
  EXPECT_EQ(field_of(R"({"base": "base.json", "variants": [{"name": "A"}, {"name": "A"}]})"), "variants[1].name");
  EXPECT_EQ(field_of(R"({"base": "base.json", "fidelity": "ultra", "variants": [{"name": "A"}]})"), "fidelity");
  EXPECT_EQ(field_of(R"({"base": "base.json", "variants": [{"name": "A"}], "colour": 1})"), "colour");
  EXPECT_EQ(field_of(R"({"base": "base.json", "factorial": {"structures": ["Dam1", "Nope"]}})"), "factorial.structures");
}
