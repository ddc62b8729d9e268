// The screening rung (issue 44 item 2): a terrain scene run with the thickness-integrated model
// ("model": "screening", or `--fidelity screening`), its outputs under the 3D run's keys.
//
// Aims and tolerances, declared 2026-12-05 before the first run of each case:
//
// (a) Stopping on the energy-line test's profiles (tests/scenarios/energy_line_test.cpp, scenes A and B: the same
//     DEMs, block 20 x 12 x 2 m, friction-HBP phi 20 deg, dp 1 m, the same rest test, at most 60 s), screened
//     at spacing 1 m with the material's bed coefficient mu = sin phi = 0.342 (Coulomb). Reference: the rigid
//     Coulomb block with the bend's centripetal load from the centre of mass's start (that test's block_reach;
//     A 126.9 m, B 122.6 m from the 3D run's start). The 3D rung measured 125.9 m (A) and 121.2 m (B)
//     (docs/validation.md section 10). Aim: the screening centre of mass's horizontal travel within 10 % of
//     the block's (the 3D rung's tolerance), the run at rest within 60 s, volume exact.
// (b) A check dam across a synthetic V channel (12 deg fall, side slopes 1 : 4, 160 x 60 m, 0.5 m cells), axis
//     across the whole width at x = 80 m, crest 3 m over the thalweg, 2 m thick; Coulomb mu 0.2 (screening.friction,
//     the override), spacing 0.5 m, 60 s. The release is a block just upstream of the dam. Held: volume 0.5 x the
//     dam's storage capacity (the terrain's, below the crest): at most 1 % of it downstream of the axis at 60 s
//     (released - upstream_volume_m3 - corridor outflow). Overtopped: 3 x the storage: at least 25 % of the excess
//     over the storage downstream at 60 s, and a protected zone downstream inundated (> 0 m2) where the held
//     case leaves it dry (0 m2). Control: the held volume with no dam runs past the axis: its centre of mass
//     ends downstream of the axis and the zone is inundated (> 0 m2).
//     Measured: held 0 m3 downstream (passes); overtopped 0 m3 downstream, the zone dry (known failure: a Coulomb
//     wedge holds far more than the level-pond storage); control at x 99.8 m, zone 60 m2, but the run failed on
//     corridor outflow, the front at the channel's end at 11.5 s (known failure).
// (b') declared 2026-12-05 after (b)'s run, before its own: as (b) with mu 0.05 (a deposit surface of 2.9 deg,
//     near level, as the storage assumes) and terrain.corridor.max_outflow 1 (the channel's end open; what leaves
//     there counts downstream: released - upstream_volume_m3): held 0.5 x storage, at most 1 % downstream and
//     the zone dry; overtopped 3 x storage, at least 25 % of the excess downstream and the zone inundated.
//     Control with max_outflow 1 and mu 0.2: centre of mass past the axis, the zone inundated.
// (c) Volume exact (|mass.relative_error| <= 1e-12) and the 3D run's keys present (status, steps,
//     simulated_time_s, wall_time_s, mass, centre_of_mass, terrain.inundation.{inundated_area_m2, max_depth_m,
//     runout_m}, terrain.structures, terrain.protected_zones, rasters/max_depth.tif); a bad screening field, an
//     unknown one and a hydrograph release refused naming the field; --fidelity screening resolves to the model and
//     the manifest records the fidelity.
// (d) declared 2026-12-05 after (a)-(c) ran, before its own run: gauges. A section across the open channel at
//     x = 100 m (b' control, no dam): arrival_time_s > 0, peak_discharge_m3_s > 0, 0 < volume_passed_m3 <=
//     released; the same section behind the held dam of (b') passes nothing (0 m3, arrival -1). The held dam's
//     screening_load at the end of (b')'s held run (60 s, series/screening_load_dam.csv's last row) between 0.4
//     and 1.1 times rho g V tan(theta), the horizontal thrust of a frictionless level pond of volume V on a bed of
//     slope theta: bed friction (mu 0.05) can carry up to mu / tan(theta) = 24 % of it, and the flow is sampled
//     1.75 m in front of the axis, where a level pond of the held volume (2.26 m deep at the wall) is 0.37 m
//     shallower (up to 42 % less thrust).
//     Measured: section 2.0 s, passed within (0, V] (passes); behind the held dam the section counts 0.453 m3 at
//     8.5 s, the surge's splash (b') measured past the axis (known failure, declared against (b')'s own figure);
//     the held dam's load at 60 s 0.90 of rho g V tan(theta) (passes).
// (e) declared 2026-12-05 when hydrograph releases were added (they were refused in (c) until then, and (c)'s
//     refusal check became this case), before its run: the open channel of (b') with no dam, mu 0.2, a hydrograph
//     line across it at x = 40 m (y 20-40 m), depth 1 m, a surge of 100 m3 over 10 s, 60 s, a section at x = 100 m:
//     completed; the hydrograph's integral within 1 % of 100 m3; the volume entered below it by less than one row
//     (depth x spacing x line length = 10 m3); volume exact (|relative_error| <= 1e-12); the section passes a
//     volume in (0, entered].
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/engine/depth_averaged.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/scenarios/tradeoff.hpp"
#include "runout/terrain/terrain.hpp"
#include "bend_profile.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;
constexpr double kE0 = 500000.0, kN0 = 5000000.0, kZ0 = 300.0;
constexpr double kG = 9.81, kDeg = M_PI / 180;

json map_point(double x, double y) { return {kE0 + x, kN0 + y}; }
json rect(double x0, double x1, double y0, double y1) {
  return {map_point(x0, y0), map_point(x1, y0), map_point(x1, y1), map_point(x0, y1)};
}

template <class Ground>
void write_dem(const fs::path& path, double length, double width, double cell, Ground ground) {
  const int nx = static_cast<int>(length / cell), ny = static_cast<int>(width / cell);
  std::ofstream out(path);
  out << "ncols " << nx << "\nnrows " << ny << "\nxllcorner " << std::fixed << kE0 << "\nyllcorner " << kN0
      << "\ncellsize " << cell << "\nNODATA_value -9999\n";
  out.precision(4);
  for (int row = 0; row < ny; ++row)  // the first row is the north edge
    for (int i = 0; i < nx; ++i)
      out << ground((i + 0.5) * cell, width - (row + 0.5) * cell) << (i + 1 < nx ? " " : "\n");
  fs::path prj = path;
  fs::copy_file(kSource / "scenarios/flume/flume_dem.prj", prj.replace_extension(".prj"),
                fs::copy_options::overwrite_existing);
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::path(RUNOUT_BINARY_DIR) / "validation" / ("screening_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

json run_in(const fs::path& dir, const json& scene, RunSummary* out = nullptr) {
  std::ofstream(dir / "scene.json") << scene.dump(2);
  RunOptions opt;
  opt.out_dir = dir / "out";
  const RunSummary s = run_scene(load_scene(dir / "scene.json"), opt);
  if (out) *out = s;
  EXPECT_EQ(s.status, "completed") << s.error;
  return json::parse(s.metrics_json);
}

// ---- (a) the energy-line profiles (tests/bend_profile.hpp, shared with tests/scenarios/energy_line_test.cpp) ----

using Profile = runout_test::BendProfile;
constexpr double kLength = 240.0, kWidth = 80.0, kPhiDeg = 20.0;
const Profile& kSceneA = runout_test::kBendA;
const Profile& kSceneB = runout_test::kBendB;

double block_reach(const Profile& p, double x0, double mu) { return runout_test::block_reach(p, x0, mu, kLength, kG); }

json bend_scene(const Profile& p) {
  const double y0 = 0.5 * kWidth - 6, y1 = 0.5 * kWidth + 6;
  return {{"name", std::string("screening-bend-") + p.name},
          {"dimensions", 3},
          {"dp", 1.0},
          {"duration", 60.0},
          {"model", "screening"},
          {"materials",
           {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0},
             {"flow_index", 1.05}, {"regularisation", 100}, {"friction_angle", kPhiDeg}, {"cohesion", 0}}}},
          {"terrain", {{"dem", "bend.asc"}, {"corridor", {{"polygon", rect(1, kLength - 1, 1, kWidth - 1)}}}}},
          {"release", {{"polygon", rect(p.release_from, p.release_to, y0, y1)}, {"depth", 2.0}, {"material", "debris"}}},
          {"output", {{"series_interval", 0.5}, {"rest_speed", 0.5}, {"rest_quantile", 0.95}, {"rest_time", 2.0}}}};
}

TEST(ScreeningRun, CentreOfMassStopsWhereACoulombBlockWithTheBendsLoadStops) {
  for (const Profile& p : {kSceneA, kSceneB}) {
    SCOPED_TRACE(p.name);
    const fs::path dir = fresh_dir(std::string("bend_") + p.name);
    write_dem(dir / "bend.asc", kLength, kWidth, 1.0, [&](double x, double) { return p.ground(x); });
    RunSummary run;
    const json m = run_in(dir, bend_scene(p), &run);
    ASSERT_FALSE(m["centre_of_mass"].is_null());
    const double x0 = m["centre_of_mass"]["start_map"][0].get<double>() - kE0;
    const double travel = m["centre_of_mass"]["horizontal_travel_m"].get<double>();
    const double block = block_reach(p, x0, std::sin(kPhiDeg * kDeg));
    std::printf("  scene %s: %ld steps, %.2f s wall, ended at %.1f s; centre from x %.2f m, travel %.2f m, "
                "block %.2f m (%+.2f %%), travel angle %.2f deg\n",
                p.name, run.steps, run.wall_seconds, run.simulated_time, x0, travel, block,
                100 * (travel / block - 1), m["centre_of_mass"]["travel_angle_deg"].get<double>());
    EXPECT_GE(run.ended_at_rest, 0) << "not at rest within 60 s";
    EXPECT_NEAR(travel, block, 0.10 * block);
    EXPECT_LE(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
  }
}

// ---- (b) a check dam across a V channel ----

constexpr double kChLength = 160.0, kChWidth = 60.0, kDamX = 80.0, kSlope = 12.0, kSide = 0.25;
double channel(double x, double y) { return kZ0 - std::tan(kSlope * kDeg) * x + kSide * std::abs(y - 0.5 * kChWidth); }

json channel_scene(double volume, double release_length, double release_half_width, bool dam) {
  const double yc = 0.5 * kChWidth;
  json s = {{"name", "screening-dam"},
            {"dimensions", 3},
            {"dp", 0.5},
            {"duration", 60.0},
            {"model", "screening"},
            {"materials",
             {{{"name", "debris"}, {"rheology", "friction-hbp"}, {"density", 2000}, {"viscosity", 1.0},
               {"flow_index", 1.05}, {"regularisation", 100}, {"friction_angle", 30.0}, {"cohesion", 0}}}},
            {"screening", {{"spacing", 0.5}, {"friction", {{"law", "coulomb"}, {"mu", 0.2}}}}},
            {"terrain", {{"dem", "channel.asc"}, {"corridor", {{"polygon", rect(1, kChLength - 1, 1, kChWidth - 1)}}}}},
            {"release", {{"polygon", rect(kDamX - 2 - release_length, kDamX - 2, yc - release_half_width,
                                          yc + release_half_width)},
                         {"volume", volume},
                         {"material", "debris"}}},
            {"protected_zones", {{{"name", "road"}, {"polygon", rect(kDamX + 20, kDamX + 40, yc - 6, yc + 6)}}}},
            {"output", {{"series_interval", 0.5}}}};
  if (dam)
    s["structures"] = {{{"type", "check_dam"}, {"name", "dam"}, {"axis", {map_point(kDamX, 1), map_point(kDamX, kChWidth - 1)}},
                        {"crest_height", 3.0}, {"thickness", 2.0}}};
  return s;
}

// Volume past the dam's axis at the end: released, less what is upstream of it, less what left the corridor.
double downstream(const json& m, double released) {
  return released - m["terrain"]["structures"][0]["upstream_volume_m3"].get<double>() -
         m["terrain"]["corridor_outflow"]["mass_kg"].get<double>() / 2000.0;
}

double road(const json& m) { return m["terrain"]["protected_zones"][0]["inundated_area_m2"].get<double>(); }

// The dam's storage capacity below its crest (the terrain's), and a folder with the channel's DEM.
double dam_storage(const fs::path& dir) {
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  std::ofstream(dir / "probe.json") << channel_scene(10.0, 10, 4, true).dump(2);
  const double storage = load_scene(dir / "probe.json").terrain->structures.at(0).storage_capacity;
  std::printf("  dam storage capacity %.1f m3\n", storage);
  return storage;
}

// (b) as declared, mu 0.2: the held case.
TEST(ScreeningRun, CheckDamHoldsAFrictionalFlowBelowItsStorage) {
  const fs::path dir = fresh_dir("dam_held");
  const double storage = dam_storage(dir), v = 0.5 * storage;
  const json held = run_in(dir, channel_scene(v, 10, 4, true));
  const double down = downstream(held, v);
  std::printf("  held: %.1f m3 released, %.3f m3 (%.3f %%) downstream, road %.1f m2, %ld steps\n", v, down,
              100 * down / v, road(held), held["steps"].get<long>());
  EXPECT_LE(down, 0.01 * v);
  EXPECT_EQ(road(held), 0.0);
}

// Known failure (tests/CMakeLists.txt, WILL_FAIL), (b) as declared, mu 0.2: three times the storage stays behind
// the dam (0.0 m3 downstream at 60 s, measured 2026-12-05). The storage is a level pond below the crest, but a
// Coulomb deposit's surface stands at up to atan(mu) = 11.3 deg on a 12 deg bed: its wedge holds far more.
TEST(ScreeningRun, DISABLED_CheckDamIsOvertoppedByAFrictionalFlowThreeTimesItsStorage) {
  const fs::path dir = fresh_dir("dam_over");
  const double storage = dam_storage(dir), v = 3.0 * storage;
  const json over = run_in(dir, channel_scene(v, 28, 6, true));
  const double down = downstream(over, v);
  std::printf("  overtopped: %.1f m3 released, %.1f m3 downstream (%.1f %% of the excess), road %.1f m2\n", v, down,
              100 * down / (v - storage), road(over));
  EXPECT_GE(down, 0.25 * (v - storage));
  EXPECT_GT(road(over), 0.0);
}

// Known failure (WILL_FAIL), (b)'s control as declared: the front reaches the channel's end (x 159 m) at 11.5 s
// and the run fails on corridor outflow (1.25 % > 1 %); its aims (centre past the axis: 99.8 m; road 60 m2) held.
TEST(ScreeningRun, DISABLED_FlowWithoutTheDamPassesTheAxisWithinTheCorridor) {
  const fs::path dir = fresh_dir("no_dam");
  const double v = 0.5 * dam_storage(dir);
  const json free = run_in(dir, channel_scene(v, 10, 4, false));
  const double com_x = free["centre_of_mass"]["end_map"][0].get<double>() - kE0;
  std::printf("  no dam: centre of mass at x %.1f m, road %.1f m2\n", com_x, road(free));
  EXPECT_GT(com_x, kDamX);
  EXPECT_GT(road(free), 0.0);
}

// Flow that leaves through the DEM's edge leaves the model as it does in the 3D run (TerrainModel::off_corridor):
// outflow, not a corridor too narrow. The limit counts only what crosses the corridor's edge inside the DEM, so
// the free flow that fails the 1 % limit over a corridor 1 m inside the DEM (the known failure above) completes
// when the corridor is the whole DEM, and what left at the channel's end is outflow.
TEST(ScreeningRun, FlowPastTheDemsEdgeIsOutflowNotACorridorTooNarrow) {
  const fs::path dir = fresh_dir("dem_edge");
  const double v = 0.5 * dam_storage(dir);
  json s = channel_scene(v, 10, 4, false);
  s["terrain"]["corridor"]["polygon"] = rect(0, kChLength, 0, kChWidth);
  const json m = run_in(dir, s);
  std::printf("  corridor = the DEM: %ld particles over the corridor's edge, %.1f kg left of %.1f kg released\n",
              m["terrain"]["corridor_outflow"]["particles"].get<long>(), m["mass"]["outflow_kg"].get<double>(), 2000 * v);
  EXPECT_EQ(m["terrain"]["corridor_outflow"]["particles"].get<long>(), 0);
  // More than the corridor's limit (the default max_outflow) left at the DEM's edge: the old rule failed this run.
  EXPECT_GT(m["mass"]["outflow_kg"].get<double>(), terrain::CorridorSpec{}.max_outflow * 2000 * v);
  // The particles still in after some left: the kinetic energy per mass of the series is theirs, so at most half
  // the square of their fastest speed (until 2026-12-07 it was summed with the speeds of the particles before
  // them in the order, read past the list's end once a particle had left: 2 891 J/kg at 59 m/s on Alr).
  std::ifstream csv(dir / "out" / "series" / "run.csv");
  std::string line;
  std::getline(csv, line);
  int rows = 0, after_outflow = 0;
  while (std::getline(csv, line)) {
    double t, ke, vmax, fluid, outflow;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf", &t, &ke, &vmax, &fluid, &outflow), 5) << line;
    ++rows, after_outflow += outflow > 0;
    EXPECT_GE(ke, 0) << "t = " << t;
    EXPECT_LE(ke, 0.5 * vmax * vmax * (1 + 1e-12)) << "t = " << t;
  }
  EXPECT_GT(after_outflow, 0);
  EXPECT_GT(rows, after_outflow);
}

// (b') declared after (b)'s run, before its own: a nearly frictionless flow (mu 0.05) levels behind the dam as
// the storage assumes; the channel's end open (max_outflow 1), so what passes counts downstream.
json open_channel(double volume, double length, double half_width, bool dam, double mu) {
  json s = channel_scene(volume, length, half_width, dam);
  s["screening"]["friction"]["mu"] = mu;
  s["terrain"]["corridor"]["max_outflow"] = 1.0;
  return s;
}

TEST(ScreeningRun, CheckDamHoldsALevellingFlowBelowItsStorageAndIsOvertoppedAboveIt) {
  const fs::path dir = fresh_dir("dam_levelling");
  const double storage = dam_storage(dir), held_v = 0.5 * storage, over_v = 3.0 * storage;
  const json held = run_in(dir, open_channel(held_v, 10, 4, true, 0.05));
  const double held_down = held_v - held["terrain"]["structures"][0]["upstream_volume_m3"].get<double>();
  const json over = run_in(dir, open_channel(over_v, 28, 6, true, 0.05));
  const double over_down = over_v - over["terrain"]["structures"][0]["upstream_volume_m3"].get<double>();
  std::printf("  held: %.1f m3, %.3f m3 (%.3f %%) downstream, road %.1f m2; overtopped: %.1f m3, %.1f m3 downstream "
              "(%.1f %% of the excess), road %.1f m2\n", held_v, held_down, 100 * held_down / held_v, road(held),
              over_v, over_down, 100 * over_down / (over_v - storage), road(over));
  EXPECT_LE(held_down, 0.01 * held_v);
  EXPECT_EQ(road(held), 0.0);
  EXPECT_GE(over_down, 0.25 * (over_v - storage));
  EXPECT_GT(road(over), 0.0);
}

TEST(ScreeningRun, FlowWithoutTheDamPassesTheAxis) {
  const fs::path dir = fresh_dir("no_dam_open");
  const double v = 0.5 * dam_storage(dir);
  const json free = run_in(dir, open_channel(v, 10, 4, false, 0.2));
  const double com_x = free["centre_of_mass"]["end_map"][0].get<double>() - kE0;
  std::printf("  no dam: centre of mass at x %.1f m, road %.1f m2\n", com_x, road(free));
  EXPECT_GT(com_x, kDamX);
  EXPECT_GT(road(free), 0.0);
}

// ---- (d) gauges ----

json with_section(json scene) {
  scene["monitors"] = {{{"type", "section"}, {"name", "x100"}, {"line", {map_point(100, 1), map_point(100, kChWidth - 1)}}}};
  return scene;
}

TEST(ScreeningRun, SectionCountsTheVolumePassed) {
  const fs::path dir = fresh_dir("gauges_free");
  const double v = 0.5 * dam_storage(dir);
  const json free = run_in(dir, with_section(open_channel(v, 10, 4, false, 0.2)));
  ASSERT_EQ(free["monitors"].size(), 1u);
  const json& sec = free["monitors"][0];
  std::printf("  no dam: section x100 arrival %.2f s, peak %.2f m3/s at %.2f s, passed %.2f of %.2f m3\n",
              sec["arrival_time_s"].get<double>(), sec["peak_discharge_m3_s"].get<double>(),
              sec["time_of_peak_s"].get<double>(), sec["volume_passed_m3"].get<double>(), v);
  EXPECT_GT(sec["arrival_time_s"].get<double>(), 0.0);
  EXPECT_GT(sec["peak_discharge_m3_s"].get<double>(), 0.0);
  EXPECT_GT(sec["volume_passed_m3"].get<double>(), 0.0);
  EXPECT_LE(sec["volume_passed_m3"].get<double>(), v + 1e-9);
  EXPECT_TRUE(fs::exists(dir / "out" / "series" / "section_x100.csv"));
}

// Known failure (WILL_FAIL), (d) as declared: the section behind the held dam counts 0.453 m3 arriving at 8.5 s,
// the 0.625 % of the held volume that (b') measured past the axis (the surge's splash over the crest): the aim
// of nothing passing contradicted (b')'s own measurement, which it should have been declared from.
TEST(ScreeningRun, DISABLED_SectionBehindTheHeldDamPassesNothing) {
  const fs::path dir = fresh_dir("gauges_held_section");
  const double v = 0.5 * dam_storage(dir);
  const json held = run_in(dir, with_section(open_channel(v, 10, 4, true, 0.05)));
  EXPECT_EQ(held["monitors"][0]["volume_passed_m3"].get<double>(), 0.0);
  EXPECT_EQ(held["monitors"][0]["arrival_time_s"].get<double>(), -1.0);
}

TEST(ScreeningRun, DamLoadIsTheHeldPondsThrust) {
  const fs::path dir = fresh_dir("gauges_load");
  const double v = 0.5 * dam_storage(dir);
  const json held = run_in(dir, open_channel(v, 10, 4, true, 0.05));
  const json& load = held["terrain"]["structures"][0]["screening_load"];
  std::ifstream csv(dir / "out" / "series" / "screening_load_dam.csv");
  std::string line, last;
  while (std::getline(csv, line))
    if (!line.empty()) last = line;
  const double end_force = std::stod(last.substr(last.find(',') + 1));
  const double thrust = 2000 * kG * v * std::tan(kSlope * kDeg);
  std::printf("  held dam: force at the end %.0f N, peak %.0f N at %.1f s, peak line load %.0f N/m; rho g V tan = %.0f N "
              "(end %.2f of it)\n", end_force, load["peak_force_n"].get<double>(),
              load["time_of_peak_force_s"].get<double>(), load["peak_line_load_n_m"].get<double>(), thrust,
              end_force / thrust);
  EXPECT_GE(end_force, 0.4 * thrust);
  EXPECT_LE(end_force, 1.1 * thrust);
}

// ---- (e) a hydrograph release ----

TEST(ScreeningRun, HydrographEntersItsVolumeAcrossTheLine) {
  const fs::path dir = fresh_dir("hydrograph");
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  json scene = with_section(open_channel(40.0, 10, 4, false, 0.2));
  scene["release"] = {{"hydrograph", {{"line", {map_point(40, 20), map_point(40, 40)}}, {"depth", 1.0},
                                      {"volume", 100.0}, {"duration", 10.0}}},
                      {"material", "debris"}};
  RunSummary run;
  const json m = run_in(dir, scene, &run);
  const json& in = m["screening"]["inflow"];
  const double due = in["volume_due_m3"].get<double>(), entered = in["volume_entered_m3"].get<double>();
  const double passed = m["monitors"][0]["volume_passed_m3"].get<double>();
  std::printf("  hydrograph: due %.3f m3, entered %.3f m3, %zu particles, section passed %.2f m3, %ld steps, "
              "relative error %.2e\n", due, entered, m["particles"]["fluid_final"].get<size_t>(), passed, run.steps,
              m["mass"]["relative_error"].get<double>());
  EXPECT_NEAR(due, 100.0, 1.0);
  EXPECT_LE(entered, due + 1e-9);
  EXPECT_GT(entered, due - 10.0);
  EXPECT_LE(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
  EXPECT_GT(passed, 0.0);
  EXPECT_LE(passed, entered + 1e-9);
}

// ---- (c) outputs, volume, refusals, the fidelity preset ----

TEST(ScreeningRun, WritesTheThreeDRunsKeysWithTheVolumeExact) {
  const fs::path dir = fresh_dir("keys");
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  json scene = channel_scene(40.0, 10, 4, true);
  scene["duration"] = 5.0;
  const json m = run_in(dir, scene);
  EXPECT_EQ(m["model"], "screening");
  for (const char* k : {"status", "steps", "simulated_time_s", "wall_time_s", "mass", "centre_of_mass", "final_speed"})
    EXPECT_TRUE(m.contains(k)) << k;
  for (const char* k : {"inundated_area_m2", "max_depth_m", "runout_m", "max_speed_m_s"})
    EXPECT_TRUE(m["terrain"]["inundation"].contains(k)) << k;
  EXPECT_TRUE(m["terrain"].contains("structures"));
  EXPECT_TRUE(m["terrain"].contains("protected_zones"));
  EXPECT_TRUE(fs::exists(dir / "out" / "rasters" / "max_depth.tif"));
  EXPECT_TRUE(fs::exists(dir / "out" / "series" / "run.csv"));
  EXPECT_LE(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
  EXPECT_NEAR(m["terrain"]["release_volume_m3"].get<double>(), 40.0, 1e-9);
  EXPECT_GT(m["terrain"]["inundation"]["max_depth_m"].get<double>(), 0.0);
}

TEST(ScreeningRun, RefusesABadScreeningFieldNamingIt) {
  const fs::path dir = fresh_dir("refusals");
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  auto refused = [&](json scene) -> std::string {
    try {
      (void)parse_scene(scene.dump(), dir);
    } catch (const SceneError& e) {
      return e.field + " | " + e.what();
    }
    return "accepted";
  };
  json s = channel_scene(40.0, 10, 4, true);
  s["screening"]["cfl"] = 2.0;
  EXPECT_NE(refused(s).find("screening.cfl | screening.cfl: must be a number in (0, 1]"), std::string::npos) << refused(s);
  s = channel_scene(40.0, 10, 4, true);
  s["screening"]["spacings"] = 1.0;
  EXPECT_EQ(refused(s).rfind("screening.spacings | ", 0), 0u) << refused(s);
  s = channel_scene(40.0, 10, 4, true);
  s["screening"]["friction"] = {{"law", "voellmy"}, {"mu", 0.2}, {"xi", -1}};
  EXPECT_EQ(refused(s).rfind("screening.friction.xi | ", 0), 0u) << refused(s);
  s = channel_scene(40.0, 10, 4, true);
  s["screening"]["curvature"] = "yes";
  EXPECT_EQ(refused(s).rfind("screening.curvature | ", 0), 0u) << refused(s);
  s = channel_scene(40.0, 10, 4, true);
  s["model"] = "sph2d";
  EXPECT_EQ(refused(s).rfind("model | ", 0), 0u) << refused(s);
  // Savage-Hutter earth pressure: its internal friction angle required, and not under the bed's atan(mu).
  s = channel_scene(40.0, 10, 4, true);
  s["screening"]["earth_pressure_rule"] = "savage_hutter";
  EXPECT_EQ(refused(s).rfind("screening.internal_friction_angle | ", 0), 0u) << refused(s);
  s["screening"]["earth_pressure_rule"] = "anisotropic";
  EXPECT_EQ(refused(s).rfind("screening.earth_pressure_rule | ", 0), 0u) << refused(s);
  s["screening"]["earth_pressure_rule"] = "savage_hutter";
  s["screening"]["friction"] = {{"law", "coulomb"}, {"mu", 0.5}};
  s["screening"]["internal_friction_angle"] = 20;  // atan 0.5 = 26.6 deg
  EXPECT_NE(refused(s).find("accepted range [26.57, 90)"), std::string::npos) << refused(s);
  s["screening"]["internal_friction_angle"] = 30;
  EXPECT_EQ(refused(s), "accepted");
  s["screening"].erase("earth_pressure_rule");
  EXPECT_EQ(refused(s).rfind("screening.internal_friction_angle | ", 0), 0u) << refused(s);
}

// A screening scene is built without the 3D particles its rung does not run (fluid, walls, the bed's wall
// source), and limits.max_particles counts the rung's own particles: the same scene as sph3d makes more.
TEST(ScreeningRun, AScreeningSceneBuildsNoThreeDParticlesAndItsLimitCountsItsOwn) {
  const fs::path dir = fresh_dir("own_particles");
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  json s = channel_scene(40.0, 10, 4, true);
  const Scene screening = parse_scene(s.dump(), dir);
  const auto& built = std::get<SceneSetup<3>>(screening.setup);
  EXPECT_EQ(built.fluid.size(), 0u);
  EXPECT_EQ(built.boundary.size(), 0u);
  EXPECT_EQ(built.wall_source, nullptr);
  json as_3d = s;
  as_3d["model"] = "sph3d";
  const Scene sph = parse_scene(as_3d.dump(), dir);
  const auto& full = std::get<SceneSetup<3>>(sph.setup);
  ASSERT_NE(full.wall_source, nullptr);
  EXPECT_GT(static_cast<long>(full.fluid.size() + full.boundary.size() + full.wall_source->total()),
            std::lround(cost_features(screening).fluid_peak));

  // At a spacing of 0.04 m the rung's 250 x 200 particles are more than the terrain's own guard on its bed grid
  // at dp needs (316 x 120 columns, terrain/src/corridor.cpp: columns x layers <= 4 x the limit), so the limit
  // binds on them alone.
  s["screening"]["spacing"] = 0.04;
  const long own = std::lround(cost_features(parse_scene(s.dump(), dir)).fluid_peak);
  ASSERT_EQ(own, 250 * 200);
  s["limits"]["max_particles"] = own;
  EXPECT_NO_THROW((void)parse_scene(s.dump(), dir));
  s["limits"]["max_particles"] = own - 1;
  try {
    (void)parse_scene(s.dump(), dir);
    ADD_FAILURE() << "a limit under the rung's " << own << " particles was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, "screening.spacing") << e.what();
  }
}

// The rule reaches the model and the record: a run with it completes and metrics.json carries the coefficients.
TEST(ScreeningRun, SavageHutterEarthPressureIsRunAndRecorded) {
  const fs::path dir = fresh_dir("earth");
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  json scene = channel_scene(40.0, 10, 4, true);
  scene["duration"] = 5.0;
  scene["screening"]["friction"] = {{"law", "coulomb"}, {"mu", 0.5}};
  scene["screening"]["earth_pressure_rule"] = "savage_hutter";
  scene["screening"]["internal_friction_angle"] = 30;
  const json m = run_in(dir, scene);
  EXPECT_EQ(m["status"], "completed");
  const json& sc = m["screening"];
  EXPECT_EQ(sc["earth_pressure_rule"], "savage_hutter");
  EXPECT_NEAR(sc["bed_friction_angle_deg"].get<double>(), std::atan(0.5) * 180 / M_PI, 1e-12);
  const auto e = depth_averaged::savage_hutter_coefficients(30, std::atan(0.5) * 180 / M_PI);
  EXPECT_DOUBLE_EQ(sc["k_x"]["active"].get<double>(), e.kx[0]);
  EXPECT_LT(e.kx[0], e.kx[1]);  // delta < phi: active under passive
  EXPECT_LE(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
}

TEST(ScreeningRun, FidelityScreeningSelectsTheModelAndIsRecorded) {
  const fs::path dir = fresh_dir("fidelity");
  write_dem(dir / "channel.asc", kChLength, kChWidth, 0.5, channel);
  json s = channel_scene(40.0, 10, 4, true);
  s.erase("model");
  Fidelity f;
  f.name = "screening";
  const std::string resolved = resolve_scene(s.dump(), f);
  EXPECT_EQ(json::parse(resolved)["model"], "screening");
  EXPECT_EQ(json::parse(resolved)["dp"], 0.5);
  EXPECT_EQ(json::parse(make_manifest(resolved, dir, f).json)["fidelity"], "screening");
  (void)parse_scene(resolved, dir);  // valid as resolved

  // Not a dp level: `runout tradeoff` refuses it before running anything.
  RunStore store(dir / "runout.db");
  TradeoffSpec spec;
  spec.name = "t";
  spec.base_json = s.dump();
  spec.base_dir = dir;
  spec.levels = {"screening", "standard"};
  try {
    (void)run_tradeoff(store, spec, TradeoffRunOptions{});
    ADD_FAILURE() << "screening accepted as a tradeoff level";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, "levels");
  }
}

}  // namespace
