// Ensembles of a sweep (docs/scene-format.md, "Ensembles"): a seed repeats an ensemble bit for bit, the Latin
// hypercube puts one member in each stratum of every sampled parameter, grids are the product of their axes,
// members are every layout at every member's values, and bad ensembles are refused naming the field.
#include <gtest/gtest.h>

#include <boost/math/distributions/normal.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

// A small 2D granular column: parsing it costs milliseconds (a terrain scene's DEM costs seconds a parse, and
// the sweep parses each layout and the members at each parameter's extremes).
json base_scene() {
  return json::parse(R"({
    "name": "ensemble-column", "dimensions": 2, "dp": 0.01, "duration": 0.1,
    "materials": [{"name": "sand", "rheology": "friction-hbp", "density": 2000, "viscosity": 1.0, "flow_index": 1.05,
                   "regularisation": 100, "friction_angle": 20, "cohesion": 0}],
    "fluid": [{"min": [0, 0], "max": [0.1, 0.2], "material": "sand"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.6, 0.4]}]
  })");
}

struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("runout-ensemble-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  TempDir() {
    fs::create_directories(path);
    std::ofstream(path / "base.json") << base_scene().dump();
  }
  ~TempDir() { fs::remove_all(path); }
};

std::string sweep_with(const std::string& ensemble) {
  return R"({"name": "ens", "base": "base.json", "variants": [{"name": "G0"}, {"name": "G1"}], "ensemble": )" + ensemble + "}";
}

const char* kSampled = R"({"members": 16, "seed": 7, "parameters": [
  {"pointer": "/materials/0/friction_angle", "distribution": "uniform", "min": 18, "max": 24},
  {"pointer": "/materials/0/density", "distribution": "normal", "mean": 2000, "sd": 100}]})";

}  // namespace

TEST(Ensemble, TheSameSeedGivesTheSameMembersBitForBitAndAnotherSeedOthers) {
  TempDir tmp;
  const Sweep a = parse_sweep(sweep_with(kSampled), tmp.path);
  const Sweep b = parse_sweep(sweep_with(kSampled), tmp.path);
  std::string other = kSampled;
  other.replace(other.find("\"seed\": 7"), 9, "\"seed\": 8");
  const Sweep c = parse_sweep(sweep_with(other), tmp.path);
  ASSERT_EQ(a.variants.size(), 32u);  // 2 layouts x 16 members
  ASSERT_EQ(b.variants.size(), a.variants.size());
  size_t same_as_other = 0;
  for (size_t k = 0; k < a.variants.size(); ++k) {
    EXPECT_EQ(a.variants[k].name, b.variants[k].name);
    ASSERT_EQ(a.variants[k].parameters.size(), 2u);
    for (size_t p = 0; p < 2; ++p) {
      const double x = a.variants[k].parameters[p].value, y = b.variants[k].parameters[p].value;
      EXPECT_EQ(std::memcmp(&x, &y, sizeof x), 0) << a.variants[k].name;
      same_as_other += x == c.variants[k].parameters[p].value;
    }
    EXPECT_EQ(resolve_variant(a.base_json, a.variants[k], a.fidelity), resolve_variant(b.base_json, b.variants[k], b.fidelity));
  }
  EXPECT_EQ(same_as_other, 0u) << "another seed must draw other values";
}

// One member in each of the n strata of every parameter, in the parameter's own distribution: exactly k members
// lie below its k/n quantile, for every k (the defining property of a Latin hypercube; a plain random sample of
// 16 breaks it with near certainty).
TEST(Ensemble, LatinHypercubePutsOneMemberInEachStratumOfEveryParameter) {
  const auto u = latin_hypercube(64, 3, 42);
  for (size_t d = 0; d < 3; ++d) {
    std::vector<int> hits(64, 0);
    for (const auto& p : u) {
      ASSERT_GT(p[d], 0.0);
      ASSERT_LT(p[d], 1.0);
      ++hits[static_cast<size_t>(p[d] * 64)];
    }
    EXPECT_EQ(*std::min_element(hits.begin(), hits.end()), 1) << "dimension " << d;
    EXPECT_EQ(*std::max_element(hits.begin(), hits.end()), 1) << "dimension " << d;
  }
  TempDir tmp;
  const Sweep s = parse_sweep(sweep_with(kSampled), tmp.path);
  std::vector<double> phi, density;
  for (const auto& v : s.variants)
    if (v.layout == "G0") phi.push_back(v.parameters[0].value), density.push_back(v.parameters[1].value);
  ASSERT_EQ(phi.size(), 16u);
  const boost::math::normal n(2000, 100);
  for (int k = 1; k < 16; ++k) {
    const double q_phi = 18.0 + 6.0 * k / 16.0, q_density = boost::math::quantile(n, k / 16.0);
    EXPECT_EQ(std::count_if(phi.begin(), phi.end(), [&](double x) { return x < q_phi; }), k) << k;
    EXPECT_EQ(std::count_if(density.begin(), density.end(), [&](double x) { return x < q_density; }), k) << k;
  }
}

// Lists and ranges make a grid; every layout runs at every member; names say layout and member; the member's
// values are in the scene it resolves to, and nothing else of the base changes.
TEST(Ensemble, AGridIsTheProductOfItsAxesAndEveryLayoutRunsAtEveryMember) {
  TempDir tmp;
  const Sweep s = parse_sweep(sweep_with(R"({"parameters": [
      {"pointer": "/materials/0/friction_angle", "values": [19, 21, 23]},
      {"pointer": "/materials/0/density", "range": {"min": 1500, "max": 2500, "count": 3}}]})"), tmp.path);
  ASSERT_EQ(s.variants.size(), 2u * 9u);
  std::set<std::pair<double, double>> points;
  for (size_t k = 0; k < s.variants.size(); ++k) {
    const auto& v = s.variants[k];
    EXPECT_EQ(v.member, static_cast<int>(k / 2));
    EXPECT_EQ(v.layout, k % 2 == 0 ? "G0" : "G1");
    EXPECT_EQ(v.name, v.layout + "-e00" + std::to_string(v.member));
    points.insert({v.parameters[0].value, v.parameters[1].value});
    const json r = json::parse(resolve_variant(s.base_json, v, s.fidelity));
    EXPECT_EQ(r["materials"][0]["friction_angle"].get<double>(), v.parameters[0].value);
    EXPECT_EQ(r["materials"][0]["density"].get<double>(), v.parameters[1].value);
    EXPECT_EQ(r["name"], "ensemble-column/" + v.name);
  }
  EXPECT_EQ(points.size(), 9u);
  EXPECT_EQ(points.begin()->first, 19.0);
  EXPECT_EQ(points.begin()->second, 1500.0);
  EXPECT_EQ(points.rbegin()->second, 2500.0);
}

TEST(Ensemble, BadEnsemblesAreRefusedNamingTheField) {
  TempDir tmp;
  auto field_of = [&](const std::string& ensemble) -> std::string {
    try {
      parse_sweep(sweep_with(ensemble), tmp.path);
    } catch (const SceneError& e) {
      return e.field;
    }
    return "accepted";
  };
  const std::string phi = R"("pointer": "/materials/0/friction_angle")";
  EXPECT_EQ(field_of(R"({"parameters": [{)" + phi + R"(, "values": [20]}]})"), "accepted");
  EXPECT_EQ(field_of(R"({"parameters": []})"), "ensemble.parameters");
  EXPECT_EQ(field_of(R"({"parameters": [{"pointer": "/materials/0/friction_angel", "values": [20]}]})"),
            "ensemble.parameters[0].pointer");
  EXPECT_EQ(field_of(R"({"parameters": [{"pointer": "/materials/0/name", "values": [20]}]})"),
            "ensemble.parameters[0].pointer");  // not a number
  EXPECT_EQ(field_of(R"({"parameters": [{"pointer": "materials", "values": [20]}]})"), "ensemble.parameters[0].pointer");
  EXPECT_EQ(field_of(R"({"parameters": [{)" + phi + R"(, "values": [20], "range": {"min": 1, "max": 2, "count": 2}}]})"),
            "ensemble.parameters[0]");
  EXPECT_EQ(field_of(R"({"parameters": [{)" + phi + R"(, "range": {"min": 1, "max": 2, "count": 1}}]})"),
            "ensemble.parameters[0].range.count");
  EXPECT_EQ(field_of(R"({"members": 4, "parameters": [{)" + phi + R"(, "distribution": "normal", "mean": 20, "sd": 0}]})"),
            "ensemble.parameters[0].sd");
  EXPECT_EQ(field_of(R"({"members": 4, "parameters": [{)" + phi + R"(, "distribution": "gamma", "min": 1, "max": 2}]})"),
            "ensemble.parameters[0].distribution");
  EXPECT_EQ(field_of(R"({"parameters": [{)" + phi + R"(, "distribution": "uniform", "min": 19, "max": 23}]})"),
            "ensemble.members");  // a distribution needs its number of points
  EXPECT_EQ(field_of(R"({"members": 5000, "parameters": [{)" + phi + R"(, "distribution": "uniform", "min": 19, "max": 23}]})"),
            "ensemble.members");
  EXPECT_EQ(field_of(R"({"seed": -1, "members": 4, "parameters": [{)" + phi + R"(, "distribution": "uniform", "min": 19, "max": 23}]})"),
            "ensemble.seed");
  // A sampled value outside the scene's own range (a friction angle under 0 degrees) is refused before anything
  // runs, naming the scene's field.
  const std::string wide = field_of(R"({"members": 64, "parameters": [{)" + phi +
                                    R"(, "distribution": "normal", "mean": 20, "sd": 30}]})");
  EXPECT_NE(wide.find("ensemble member"), std::string::npos) << wide;
  EXPECT_NE(wide.find("friction_angle"), std::string::npos) << wide;
}
