// Bad scene input is refused by parse_scene before any particle is made, with a SceneError whose `field` is
// the JSON path of the offending value and whose message names that field and the accepted range (or the
// accepted values). Each case edits a valid base scene (or is raw text) and states the expected field and
// the text the message must contain.
//
// Cases in kPending describe inputs the current parser accepts, crashes on, or refuses without the range;
// they are instantiated as DISABLED_ (run them with --gtest_also_run_disabled_tests) until scene.cpp is
// fixed. The fix is proposed alongside these tests.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <typeinfo>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;

namespace {

// A small valid 2D scene: a water column in a tank. 100 fluid + 228 wall particles.
json base_scene() {
  return json::parse(R"({
    "name": "base",
    "dimensions": 2,
    "dp": 0.02,
    "duration": 0.1,
    "materials": [{"name": "debris", "rheology": "newtonian", "density": 1000}],
    "fluid": [{"min": [0, 0], "max": [0.2, 0.2], "material": "debris"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.6, 0.4]}]
  })");
}

json base_scene_3d() {
  return json::parse(R"({
    "dimensions": 3,
    "dp": 0.02,
    "duration": 0.1,
    "materials": [{"name": "debris", "rheology": "newtonian", "density": 1000}],
    "fluid": [{"min": [0, 0, 0], "max": [0.1, 0.1, 0.1], "material": "debris"}],
    "boundaries": [{"type": "tank", "min": [0, 0, 0], "max": [0.2, 0.2, 0.2]}]
  })");
}

struct Case {
  std::string name;
  std::function<std::string()> text;  // the scene as given
  std::string field;                  // expected SceneError::field
  std::vector<std::string> contains;  // texts the message must contain (the range, the accepted values)
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

// Base scene edited by f.
Case edit(std::string name, std::function<void(json&)> f, std::string field, std::vector<std::string> contains,
          std::function<json()> make = base_scene) {
  return {std::move(name),
          [f, make] {
            json j = make();
            f(j);
            return j.dump();
          },
          std::move(field), std::move(contains)};
}
// Raw text (malformed JSON, or numbers nlohmann cannot represent).
Case raw(std::string name, std::string text, std::string field, std::vector<std::string> contains) {
  return {std::move(name), [text] { return text; }, std::move(field), std::move(contains)};
}
// Sets j[path...] = v, creating objects on the way.
std::function<void(json&)> set(const json::json_pointer& p, json v) {
  return [p, v](json& j) { j[p] = v; };
}
std::function<void(json&)> erase(const json::json_pointer& parent, const std::string& key) {
  return [parent, key](json& j) { j[parent].erase(key); };
}
std::function<void(json&)> material(json m) { return set(json::json_pointer("/materials/0"), std::move(m)); }
json hbp(json extra) {
  json m = {{"name", "debris"}, {"rheology", "hbp"}, {"density", 2000}, {"yield_stress", 100}};
  m.update(extra);
  return m;
}
json friction(json extra) {
  json m = {{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"friction_angle", 30}};
  m.update(extra);
  return m;
}

using P = json::json_pointer;

// The JSON text of the base scene with one number written verbatim (JSON has no NaN or infinity; a literal
// that overflows a double is the nearest a file can get).
std::string base_with_literal(const std::string& key_path_marker, const std::string& literal) {
  std::string s = base_scene().dump();
  const auto at = s.find(key_path_marker);
  return s.substr(0, at + key_path_marker.size()) + literal +
         s.substr(s.find_first_of(",}", at + key_path_marker.size()));
}

const std::vector<Case> kRefused = {
    // Missing required fields.
    edit("MissingDp", erase(P(""), "dp"), "dp", {"missing"}),
    edit("NullDp", set(P("/dp"), nullptr), "dp", {"missing"}),
    edit("MissingDuration", erase(P(""), "duration"), "duration", {"missing"}),
    edit("MissingDimensions", erase(P(""), "dimensions"), "dimensions", {"missing", "2 or 3"}),
    edit("MissingMaterials", erase(P(""), "materials"), "materials", {"missing"}),
    edit("MissingFluid", erase(P(""), "fluid"), "fluid", {"missing"}),
    edit("MissingMaterialDensity", erase(P("/materials/0"), "density"), "materials[0].density", {"missing"}),
    edit("MissingMaterialName", erase(P("/materials/0"), "name"), "materials[0].name", {"missing"}),
    edit("MissingRheology", erase(P("/materials/0"), "rheology"), "materials[0].rheology", {"missing"}),
    edit("MissingYieldStressForBingham", material({{"name", "debris"}, {"rheology", "bingham"}, {"density", 2000}}),
         "materials[0].yield_stress", {"missing", "[0, 1e7] Pa"}),
    edit("MissingYieldStressForHbp", material({{"name", "debris"}, {"rheology", "hbp"}, {"density", 2000}}),
         "materials[0].yield_stress", {"missing", "[0, 1e7] Pa"}),
    edit("MissingFrictionAngle", material({{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}}),
         "materials[0].friction_angle", {"missing", "[0, 90) degrees"}),
    edit("MissingBoundaryType", erase(P("/boundaries/0"), "type"), "boundaries[0].type", {"missing"}),
    edit("MissingPlaneLength", set(P("/boundaries/0"), {{"type", "plane"}, {"origin", {-1, 0}}}),
         "boundaries[0].length", {"missing"}),
    edit("MissingFluidSize", set(P("/fluid/0"), {{"origin", {0, 0}}, {"material", "debris"}}), "fluid[0].size",
         {"missing"}),
    edit("MissingPlaneWidthIn3D",
         set(P("/boundaries/0"), {{"type", "plane"}, {"origin", {-1, 0, 0}}, {"length", 2}}),
         "boundaries[0].width", {"missing"}, base_scene_3d),

    // Out of range: materials.
    edit("NegativeDensity", set(P("/materials/0/density"), -1000), "materials[0].density", {"(0, 100000]", "-1000"}),
    edit("ZeroDensity", set(P("/materials/0/density"), 0), "materials[0].density", {"(0, 100000]"}),
    edit("HugeDensity", set(P("/materials/0/density"), 1e300), "materials[0].density", {"(0, 100000]"}),
    edit("FlowIndexZero", material(hbp({{"flow_index", 0}})), "materials[0].flow_index", {"(0, 5]"}),
    edit("FlowIndexNegative", material(hbp({{"flow_index", -0.5}})), "materials[0].flow_index", {"(0, 5]"}),
    edit("FlowIndexAbove5", material(hbp({{"flow_index", 6}})), "materials[0].flow_index", {"(0, 5]"}),
    edit("FrictionAngle90", material(friction({{"friction_angle", 90}})), "materials[0].friction_angle", {"[0, 90)"}),
    edit("FrictionAngle120", material(friction({{"friction_angle", 120}})), "materials[0].friction_angle",
         {"[0, 90)"}),
    edit("FrictionAngleNegative", material(friction({{"friction_angle", -5}})), "materials[0].friction_angle",
         {"[0, 90)"}),
    edit("YieldStressNegative", material(hbp({{"yield_stress", -1}})), "materials[0].yield_stress",
         {"[0, 1e+07]"}),
    edit("RegularisationZero", material(hbp({{"regularisation", 0}})), "materials[0].regularisation",
         {"(0, 1e+08]"}),
    edit("ViscosityNegative", set(P("/materials/0/viscosity"), -1), "materials[0].viscosity", {"[0, 1e+08]"}),
    edit("CohesionNegative", material(friction({{"cohesion", -1}})), "materials[0].cohesion", {"[0, 1e+07]"}),
    edit("SeventeenMaterials",
         [](json& j) {
           j["materials"] = json::array();
           for (int k = 0; k < 17; ++k) {
             std::string name = std::to_string(k);  // (not "m" + ...: GCC 12 -Wrestrict false positive)
             name.insert(name.begin(), 'm');
             j["materials"].push_back({{"name", name}, {"rheology", "newtonian"}, {"density", 1000}});
           }
         },
         "materials", {"1 to 16"}),
    edit("DuplicateMaterialName",
         [](json& j) { j["materials"].push_back(j["materials"][0]); }, "materials[1].name", {"duplicate", "debris"}),

    // Out of range: run, numerics, output, limits.
    edit("DurationZero", set(P("/duration"), 0), "duration", {"(0, 100000]"}),
    edit("DpTooSmall", set(P("/dp"), 1e-5), "dp", {"[0.0001, 100]"}),
    edit("DpNegative", set(P("/dp"), -0.01), "dp", {"[0.0001, 100]"}),
    edit("DimensionsFour", set(P("/dimensions"), 4), "dimensions", {"[2, 3]"}),
    edit("GravityOutOfRange", set(P("/gravity"), {0, -2000}), "gravity[1]", {"[-1000, 1000]"}),
    edit("CflZero", set(P("/numerics/cfl"), 0), "numerics.cfl", {"(0, 1]"}),
    edit("CflAboveOne", set(P("/numerics/cfl"), 1.5), "numerics.cfl", {"(0, 1]"}),
    edit("SmoothingRatioBelowOne", set(P("/numerics/smoothing_ratio"), 0.5), "numerics.smoothing_ratio", {"[1, 3]"}),
    edit("SpeedOfSoundZero", set(P("/numerics/speed_of_sound"), 0), "numerics.speed_of_sound", {"(0, 100000]"}),
    edit("ViscosityCapNegative", set(P("/numerics/viscosity_cap"), -5), "numerics.viscosity_cap", {"(0, 1e+12]"}),
    edit("ViscosityCapFactorZero", set(P("/numerics/viscosity_cap_factor"), 0), "numerics.viscosity_cap_factor",
         {"(0, 1e+06]"}),
    edit("ShearRateFloorZero", set(P("/numerics/shear_rate_floor"), 0), "numerics.shear_rate_floor", {"(0, 1000]"}),
    edit("MinDtZero", set(P("/numerics/min_dt"), 0), "numerics.min_dt", {"(0, 1]"}),
    edit("ArtificialViscosityNegative", set(P("/numerics/artificial_viscosity"), -0.1),
         "numerics.artificial_viscosity", {"[0, 10]"}),
    edit("VerletResetStepsZero", set(P("/numerics/verlet_reset_steps"), 0), "numerics.verlet_reset_steps",
         {"[1, 1000]"}),
    // Verlet's leapfrog under a viscoplastic material's capped viscosity (tests/engine/verlet_test.cpp).
    edit("VerletWithAFrictionMaterial",
         [](json& j) {
           j["numerics"]["integrator"] = "verlet";
           j["materials"][0] = {{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000},
                                {"viscosity", 1}, {"friction_angle", 30}};
         },
         "numerics.integrator", {"'debris'", "accepted here: symplectic"}),
    edit("DepthScaleZero", set(P("/numerics/depth_scale"), 0), "numerics.depth_scale", {"(0, 100000]"}),
    edit("SeriesIntervalZero", set(P("/output/series_interval"), 0), "output.series_interval", {"(0, 10000]"}),
    edit("MaxParticlesZero", set(P("/limits/max_particles"), 0), "limits.max_particles", {"[1, 200000000]"}),
    edit("MaxParticlesFractional", set(P("/limits/max_particles"), 1.5), "limits.max_particles",
         {"[1, 200000000]"}),

    // Out of range: geometry.
    edit("LayersZero", set(P("/boundaries/0/layers"), 0), "boundaries[0].layers", {"[1, 10]"}),
    edit("LayersEleven", set(P("/boundaries/0/layers"), 11), "boundaries[0].layers", {"[1, 10]"}),
    edit("PlaneLengthZero", set(P("/boundaries/0"), {{"type", "plane"}, {"origin", {-1, 0}}, {"length", 0}}),
         "boundaries[0].length", {"(0, 1e+06]"}),
    edit("PlaneTooSteep",
         set(P("/boundaries/0"), {{"type", "plane"}, {"origin", {-1, 0}}, {"length", 2}, {"angle", 89.5}}),
         "boundaries[0].angle", {"[-89, 89]"}),
    edit("FluidAngleAbove90",
         set(P("/fluid/0"), {{"origin", {0, 0}}, {"size", {0.2, 0.2}}, {"angle", 95}, {"material", "debris"}}),
         "fluid[0].angle", {"[-90, 90]"}),
    edit("FluidSizeNegative",
         set(P("/fluid/0"), {{"origin", {0, 0}}, {"size", {0.2, -0.2}}, {"material", "debris"}}), "fluid[0].size[1]",
         {"[0, 1e+07]"}),
    edit("FluidSizeZero", set(P("/fluid/0"), {{"origin", {0, 0}}, {"size", {0.2, 0}}, {"material", "debris"}}),
         "fluid[0].size", {"> 0"}),
    edit("FluidMaxNotAboveMin", set(P("/fluid/0/max"), {0, 0.2}), "fluid[0].max", {"must exceed min"}),
    edit("FluidThinnerThanDp", set(P("/fluid/0/max"), {0.01, 0.2}), "fluid[0]", {"thinner than dp = 0.02 m"}),
    edit("DomainMaxBelowMin", set(P("/domain"), {{"min", {0, 0}}, {"max", {-1, 1}}}), "domain.max",
         {"must exceed domain.min"}),
    edit("PeriodicWithoutBounds", set(P("/domain"), {{"periodic", {true, false}}}), "domain.periodic",
         {"domain.min and domain.max"}),
    edit("PeriodicShorterThan6h",
         set(P("/domain"), {{"periodic", {true, false}}, {"min", {0, -1}}, {"max", {0.1, 1}}}), "domain.periodic",
         {"6h"}),

    edit("RestSpeedNegative", set(P("/output/rest_speed"), -1), "output.rest_speed", {"[0, 100]"}),
    edit("RestTimeZero", set(P("/output/rest_time"), 0), "output.rest_time", {"(0, 10000]"}),
    edit("RestQuantileZero", set(P("/output/rest_quantile"), 0), "output.rest_quantile", {"(0, 1]"}),
    edit("RestQuantileOverOne", set(P("/output/rest_quantile"), 1.5), "output.rest_quantile", {"(0, 1]"}),

    // A particle count over limits.max_particles.
    edit("OverMaxParticles", set(P("/limits/max_particles"), 100), "dp", {"limits.max_particles = 100"}),
    edit("OverDefaultMaxParticles",  // 3000 x 2000 fluid particles, over the default limit of 5e6
         [](json& j) {
           j["dp"] = 1e-4;
           j["fluid"][0]["max"] = {0.3, 0.2};
         },
         "dp", {"limits.max_particles = 5000000"}),
    edit("PlaneOverMaxParticles",
         [](json& j) {
           j["boundaries"][0] = {{"type", "plane"}, {"origin", {-1, 0}}, {"length", 100}};
           j["limits"]["max_particles"] = 1000;
         },
         "dp", {"limits.max_particles = 1000"}),

    // Malformed JSON, NaN-like values.
    raw("TruncatedJson", R"({"dimensions": 2, "dp": 0.02,)", "(json)", {"malformed JSON"}),
    raw("EmptyText", "", "(json)", {"malformed JSON"}),
    raw("TrailingComma", R"({"dimensions": 2,})", "(json)", {"malformed JSON"}),
    raw("NaNLiteral", base_with_literal("\"density\":", "NaN"), "(json)", {"malformed JSON"}),
    raw("InfinityLiteral", base_with_literal("\"density\":", "Infinity"), "(json)", {"malformed JSON"}),
    raw("ArrayAtRoot", "[1, 2, 3]", "(root)", {"JSON object"}),
    raw("StringAtRoot", R"("scene")", "(root)", {"JSON object"}),
    edit("DensityNaNString", set(P("/materials/0/density"), "NaN"), "materials[0].density", {"(0, 100000]"}),
    edit("DensityInfString", set(P("/materials/0/density"), "inf"), "materials[0].density", {"(0, 100000]"}),

    // Unknown fields.
    edit("UnknownTopLevelField", set(P("/dpp"), 0.01), "dpp", {"unknown field", "accepted:", "dp, duration"}),
    edit("UnknownMaterialField", set(P("/materials/0/colour"), "red"), "materials[0].colour",
         {"unknown field", "accepted:", "density"}),
    edit("UnknownFluidField", set(P("/fluid/0/mat"), "debris"), "fluid[0].mat", {"unknown field", "material"}),
    edit("UnknownNumericsField", set(P("/numerics/kernal"), "cubic"), "numerics.kernal", {"unknown field", "kernel"}),
    edit("UnknownBoundaryField", set(P("/boundaries/0/radius"), 1), "boundaries[0].radius", {"unknown field"}),
    edit("UnknownDomainField", set(P("/domain/wrap"), true), "domain.wrap", {"unknown field", "periodic"}),
    edit("UnknownOutputField", set(P("/output/format"), "vtk"), "output.format", {"unknown field", "series_interval"}),
    edit("UnknownLimitsField", set(P("/limits/max_steps"), 10), "limits.max_steps", {"unknown field", "max_particles"}),

    // Wrong types.
    edit("DpAsString", set(P("/dp"), "0.01"), "dp", {"[0.0001, 100]"}),
    edit("DpAsBoolean", set(P("/dp"), true), "dp", {"[0.0001, 100]"}),
    edit("DpAsArray", set(P("/dp"), {0.01}), "dp", {"[0.0001, 100]"}),
    edit("DimensionsAsString", set(P("/dimensions"), "2"), "dimensions", {"[2, 3]"}),
    edit("DimensionsFractional", set(P("/dimensions"), 2.5), "dimensions", {"[2, 3]"}),
    edit("NameAsNumber", set(P("/name"), 5), "name", {"string"}),
    edit("MaterialReferenceAsNumber", set(P("/fluid/0/material"), 3), "fluid[0].material", {"string"}),
    edit("FluidBlockAsNumber", set(P("/fluid/0"), 5), "fluid[0]", {"JSON object"}),
    edit("MaterialAsString", set(P("/materials/0"), "water"), "materials[0]", {"JSON object"}),
    edit("NumericsAsArray", set(P("/numerics"), json::array()), "numerics", {"JSON object"}),
    edit("GravityComponentAsString", set(P("/gravity"), {0, "down"}), "gravity[1]", {"[-1000, 1000]"}),
    edit("OpenFacesAsString", set(P("/boundaries/0/open"), "top"), "boundaries[0].open", {"array of face names"}),
    edit("PeriodicAsString", set(P("/domain"), {{"periodic", "x"}, {"min", {0, 0}}, {"max", {1, 1}}}),
         "domain.periodic", {"2 booleans"}),
    edit("ViscosityCapAsBoolean", set(P("/numerics/viscosity_cap"), true), "numerics.viscosity_cap",
         {"(0, 1e+12]"}),

    // Empty arrays.
    edit("MaterialsEmpty", set(P("/materials"), json::array()), "materials", {"1 to 16"}),
    edit("MaterialsAsObject", set(P("/materials"), json::object()), "materials", {"1 to 16"}),
    edit("FluidEmpty", set(P("/fluid"), json::array()), "fluid", {"non-empty array"}),
    edit("FluidMinEmpty", set(P("/fluid/0/min"), json::array()), "fluid[0].min", {"array of 2 numbers"}),
    edit("FluidMinTooLong", set(P("/fluid/0/min"), {0, 0, 0}), "fluid[0].min", {"array of 2 numbers"}),
    edit("GravityEmpty", set(P("/gravity"), json::array()), "gravity", {"array of 2 numbers"}),

    // Unknown names.
    edit("FluidRefersToUnknownMaterial", set(P("/fluid/0/material"), "mud"), "fluid[0].material", {"'mud'"}),
    edit("UnknownRheology", set(P("/materials/0/rheology"), "bingam"), "materials[0].rheology",
         {"'bingam'", "accepted: bingham, friction-hbp, hbp, mu-i, newtonian"}),
    edit("UnknownKernel", set(P("/numerics/kernel"), "gaussian"), "numerics.kernel",
         {"'gaussian'", "accepted: wendland, cubic"}),
    edit("UnknownIntegrator", set(P("/numerics/integrator"), "euler"), "numerics.integrator",
         {"accepted: symplectic, verlet"}),
    edit("UnknownDensityDiffusion", set(P("/numerics/density_diffusion"), "foo"), "numerics.density_diffusion",
         {"accepted: none, molteni, fourtakas"}),
    edit("UnknownViscosityCapName", set(P("/numerics/viscosity_cap"), "manual"), "numerics.viscosity_cap",
         {"accepted: auto"}),
    edit("UnknownBoundaryType", set(P("/boundaries/0/type"), "wall"), "boundaries[0].type",
         {"accepted: tank, block, plane, flume"}),
    edit("UnknownFaceName", set(P("/boundaries/0/open"), {"up"}), "boundaries[0].open[0]",
         {"'up'", "x-, x+, y-, y+, top, bottom"}),
    edit("UnknownFluidShape", set(P("/fluid/0/shape"), "sphere"), "fluid[0].shape", {"accepted: box"}),
};

// Refused only after scene.cpp is fixed (proposed diff in the report), or refused today without the range.
const std::vector<Case> kPending = {
    // A missing field should state what it accepts, like a present but bad one does.
    edit("MissingDpStatesRange", erase(P(""), "dp"), "dp", {"missing", "[0.0001, 100]"}),
    edit("MissingDurationStatesRange", erase(P(""), "duration"), "duration", {"missing", "(0, 100000]"}),
    edit("MissingDensityStatesRange", erase(P("/materials/0"), "density"), "materials[0].density",
         {"missing", "(0, 100000]"}),
    edit("MissingRheologyStatesNames", erase(P("/materials/0"), "rheology"), "materials[0].rheology",
         {"missing", "bingham, friction-hbp, hbp, mu-i, newtonian"}),
    edit("MissingMaterialsStatesRange", erase(P(""), "materials"), "materials", {"missing", "1 to 16"}),
    edit("MissingFluidStatesRange", erase(P(""), "fluid"), "fluid", {"missing", "non-empty array"}),
    edit("MissingBoundaryTypeStatesNames", erase(P("/boundaries/0"), "type"), "boundaries[0].type",
         {"missing", "tank, block, plane, flume"}),
    edit("MissingPlaneLengthStatesRange", set(P("/boundaries/0"), {{"type", "plane"}, {"origin", {-1, 0}}}),
         "boundaries[0].length", {"missing", "(0, 1e+06]"}),
    // A number beyond double range: today nlohmann's out_of_range escapes parse_scene (the CLI aborts).
    raw("NumberOverflowsDouble", base_with_literal("\"density\":", "1e400"), "(json)", {"1e400"}),
    raw("NegativeNumberOverflowsDouble", base_with_literal("\"dp\":", "-1e400"), "(json)", {"-1e400"}),
    // The refusal should list the materials that exist.
    edit("UnknownMaterialListsDefinedOnes", set(P("/fluid/0/material"), "mud"), "fluid[0].material",
         {"'mud'", "debris"}),
    // Fields that belong to another boundary type are silently ignored today.
    edit("PlaneWidthIn2D",
         set(P("/boundaries/0"), {{"type", "plane"}, {"origin", {-1, 0}}, {"length", 2}, {"width", 1}}),
         "boundaries[0].width", {"unknown field"}),
    edit("WallHeightOnBlock", set(P("/boundaries/0"), {{"type", "block"}, {"min", {0.3, 0}}, {"max", {0.4, 0.1}},
                                                        {"wall_height", 1}}),
         "boundaries[0].wall_height", {"unknown field"}),
    edit("LengthOnTank", set(P("/boundaries/0/length"), 3), "boundaries[0].length", {"unknown field"}),
    // A box given both ways: origin/size are silently ignored today.
    edit("BoxGivenTwice", set(P("/fluid/0"), {{"min", {0, 0}}, {"max", {0.2, 0.2}}, {"origin", {1, 1}},
                                              {"size", {1, 1}}, {"material", "debris"}}),
         "fluid[0]", {"min/max", "origin/size"}),
    // Fluid that starts inside a wall leaks on the first step; fluid blocks that overlap stack particles.
    edit("FluidInsideSolidBlock",
         [](json& j) { j["boundaries"].push_back({{"type", "block"}, {"min", {0.05, 0.05}}, {"max", {0.15, 0.15}}}); },
         "fluid[0]", {"boundaries[1]"}),
    edit("OverlappingFluidBlocks", [](json& j) { j["fluid"].push_back(j["fluid"][0]); }, "fluid[1]", {"fluid[0]"}),
    // A domain that leaves particles outside: every one of them leaks on the first step.
    edit("DomainExcludesParticles", set(P("/domain"), {{"min", {0.1, 0.1}}, {"max", {0.15, 0.15}}}), "domain",
         {"particle"}),
    // The solver refuses a periodic vertical axis (std::invalid_argument after the output folder exists).
    edit("PeriodicVerticalAxis", set(P("/domain"), {{"periodic", {false, true}}, {"min", {-1, -1}}, {"max", {1, 1}}}),
         "domain.periodic", {"vertical"}),
    edit("DescriptionAsNumber", set(P("/description"), 5), "description", {"string"}),
    // Inlets.
    edit("InletVerticalDirection", set(P("/inlets"), json::parse(R"([{"material": "debris", "direction": "+z",
         "at": 0.3, "min": [0], "max": [0.1], "speed": 1}])")), "inlets[0].direction", {"'+z'", "+x, -x"}),
    edit("InletOpeningThinnerThanDp", set(P("/inlets"), json::parse(R"([{"material": "debris", "direction": "+x",
         "at": 0.3, "min": [0.1], "max": [0.11], "speed": 1}])")), "inlets[0].max", {"at least dp"}),
    edit("InletSpeedAndDischarge", set(P("/inlets"), json::parse(R"([{"material": "debris", "direction": "+x",
         "at": 0.3, "min": [0], "max": [0.1], "speed": 1, "discharge": 0.1}])")), "inlets[0]", {"exactly one"}),
    edit("InletNegativeSpeed", set(P("/inlets"), json::parse(R"([{"material": "debris", "direction": "-x",
         "at": 0.3, "min": [0], "max": [0.1], "speed": -1}])")), "inlets[0].speed", {"[0, 1e+06]"}),
    edit("InletHydrographTimesGoBack", set(P("/inlets"), json::parse(R"([{"material": "debris", "direction": "+x",
         "at": 0.3, "min": [0], "max": [0.1], "discharge": [[0, 0], [2, 0.1], [1, 0]]}])")),
         "inlets[0].discharge[2][0]", {"increase"}),
    edit("InletWithDbcWalls", [](json& j) {
           j["inlets"] = json::parse(R"([{"material": "debris", "direction": "+x", "at": 0.3, "min": [0],
                                         "max": [0.1], "speed": 1}])");
           j["numerics"]["boundary_pressure"] = "dbc";
         }, "numerics.boundary_pressure", {"extrapolated"}),
    edit("InletUnknownMaterial", set(P("/inlets"), json::parse(R"([{"material": "mud", "direction": "+x",
         "at": 0.3, "min": [0], "max": [0.1], "speed": 1}])")), "inlets[0].material", {"'mud'"}),
};

class SceneRefusal : public ::testing::TestWithParam<Case> {};

TEST_P(SceneRefusal, NamesFieldAndAcceptedRange) {
  const Case& c = GetParam();
  const std::string text = c.text();
  try {
    (void)parse_scene(text);
    FAIL() << "accepted: " << text;
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, c.field) << e.what();
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(c.field + ": ", 0), 0u) << "the message must start with the field: " << msg;
    for (const auto& s : c.contains) EXPECT_NE(msg.find(s), std::string::npos) << "'" << s << "' not in: " << msg;
  } catch (const std::exception& e) {
    FAIL() << "threw " << typeid(e).name() << " instead of SceneError: " << e.what();
  }
}

auto case_name = [](const ::testing::TestParamInfo<Case>& info) { return info.param.name; };
INSTANTIATE_TEST_SUITE_P(Refused, SceneRefusal, ::testing::ValuesIn(kRefused), case_name);
INSTANTIATE_TEST_SUITE_P(PendingSceneFix, SceneRefusal, ::testing::ValuesIn(kPending), case_name);

// The refusals above are refusals of the edit, not of the base scenes.
TEST(SceneValidation, BaseScenesAreAccepted) {
  for (const json& j : {base_scene(), base_scene_3d()}) {
    const Scene s = parse_scene(j.dump());
    const size_t fluid = std::visit([](const auto& setup) { return setup.fluid.size(); }, s.setup);
    EXPECT_GT(fluid, 0u);
  }
}

// Values at the edge of each range are accepted (the ranges in the messages are the real ones).
TEST(SceneValidation, RangeEdgesAreAccepted) {
  const std::vector<std::function<void(json&)>> edits = {
      material(hbp({{"flow_index", 5}, {"regularisation", 1e8}, {"yield_stress", 1e7}, {"viscosity", 1e8}})),
      material(hbp({{"flow_index", 1e-3}, {"yield_stress", 0}, {"viscosity", 0}})),
      material(friction({{"friction_angle", 0}, {"cohesion", 1e7}})),
      material(friction({{"friction_angle", 89.999}})),
      set(P("/materials/0/density"), 1e5),
      set(P("/numerics"), {{"cfl", 1}, {"smoothing_ratio", 3}, {"artificial_viscosity", 10},
                           {"viscosity_cap", 1e12}, {"verlet_reset_steps", 1000}, {"density_diffusion_delta", 1}}),
      set(P("/numerics"), {{"smoothing_ratio", 1}, {"viscosity_cap", "auto"}, {"viscosity_cap_factor", 1e6}}),
      set(P("/gravity"), {0, -1000}),
  };
  for (size_t k = 0; k < edits.size(); ++k) {
    json j = base_scene();
    edits[k](j);
    EXPECT_NO_THROW((void)parse_scene(j.dump())) << "edit " << k << ": " << j.dump();
  }
}

// limits.max_particles bounds the particles the scene makes. Disabled: the estimate made before building
// counts a tank's whole inside (0.6 x 0.4 m at dp 0.02: 600) rather than its walls (228), so this scene of
// 328 particles is refused at a limit of 328 (and a 100 m x 100 m tank holding a small block is refused at the
// default limit although it makes 60 000 wall particles).
TEST(SceneValidation, LimitCountsTheParticlesMade) {
  json j = base_scene();
  j["limits"]["max_particles"] = 328;  // exactly 100 fluid + 228 wall particles
  EXPECT_NO_THROW((void)parse_scene(j.dump()));
  j["limits"]["max_particles"] = 327;
  EXPECT_THROW((void)parse_scene(j.dump()), SceneError);
}

// read_scene reads and checks the document without building: it opens no file (a DEM that is not there is
// build_scene's to refuse) but refuses a declared field out of its range itself; build_scene of what it read
// is the scene parse_scene makes.
TEST(SceneValidation, ReadingASceneBuildsNothingAndBuildingWhatWasReadIsParsing) {
  const json base = base_scene();
  const SceneSpec spec = read_scene(base);
  EXPECT_EQ(spec.name, "base");
  EXPECT_EQ(spec.dimensions, 2);
  EXPECT_EQ(spec.dp, 0.02);
  EXPECT_EQ(spec.duration, 0.1);
  const Scene built = build_scene(spec), parsed = parse_scene(base.dump());
  EXPECT_EQ(built.canonical_json, parsed.canonical_json);
  const auto counts = [](const Scene& s) {
    return std::visit([](const auto& setup) { return std::make_pair(setup.fluid.size(), setup.boundary.size()); },
                      s.setup);
  };
  EXPECT_EQ(counts(built), counts(parsed));

  const std::filesystem::path dir = std::filesystem::path(RUNOUT_SOURCE_DIR) / "scenarios" / "catchment";
  std::ifstream in(dir / "alr.json");
  json catchment = json::parse(in);
  catchment["terrain"]["dem"] = "no_such_dem.tif";
  SceneSpec unbuilt;
  ASSERT_NO_THROW(unbuilt = read_scene(catchment, dir));
  try {
    (void)build_scene(unbuilt);
    ADD_FAILURE() << "a scene whose DEM is missing was built";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, "terrain.dem");
  }

  catchment["numerics"]["cfl"] = 7;
  try {
    (void)read_scene(catchment, dir);
    ADD_FAILURE() << "numerics.cfl = 7 was read";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, "numerics.cfl");
  }
}

}  // namespace
