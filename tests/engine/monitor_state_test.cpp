// Monitors resumed from a checkpoint: a monitor saved mid-run and loaded into a fresh one made from the same spec
// on the same (mid-run) solver reads every later sample and its summary exactly as the saved one goes on to. The
// scenes save before the flow reaches the gauge's interesting part (a section's crossing, a wall's impact, a
// probe's wetting) and after some state has built up (a column's first, deepest readings, samples counted), so
// a member left out of a save/load pair changes a row or the summary. Not caught here: what only a sample at the
// saved instant reads (the next step overwrites it), the section's arrival volume (this tank's volume does not
// change) and the structure's members (fixed walls: the boundary is never rebuilt).
#include <gtest/gtest.h>
#include <omp.h>

#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "runout/engine/monitors.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;

namespace {

// A 2D dam break (a 0.4 m column, dp = 0.02 m) in a tank 1.2 m long whose right wall is a tagged block, and
// any other boundaries.
json dam_break_2d(const json& monitors, const json& more_boundaries = json::array()) {
  json scene = json::parse(R"({
    "dimensions": 2, "dp": 0.02, "duration": 0.8,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0}],
    "numerics": {"artificial_viscosity": 0.02, "speed_of_sound": 50},
    "fluid": [{"min": [0, 0], "max": [0.4, 0.4], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [1.2, 0.8], "open": ["x+", "top"], "tag": "tank"},
                   {"type": "block", "min": [1.2, -0.06], "max": [1.26, 0.8], "tag": "wall"}]
  })");
  scene["monitors"] = monitors;
  for (const auto& b : more_boundaries) scene["boundaries"].push_back(b);
  return scene;
}

using Summary = std::vector<std::pair<std::string, real>>;

// Runs the scene to `save_at` with monitors A (after_step every step, a sample every `every` steps), saves them
// all to one stream, makes B from the same specs on the same solver and loads them, then drives A and B alike to
// the scene's duration. Every row and summary of B must equal A's; returns A's summaries.
template <int D>
std::vector<Summary> expect_resumes_exactly(const json& scene, real save_at, int every = 40) {
  omp_set_num_threads(1);  // bit for bit: the monitors' reductions in one order
  const Scene s = parse_scene(scene.dump());
  Solver<D> solver(std::get<SceneSetup<D>>(s.setup));
  std::vector<std::unique_ptr<Monitor<D>>> a, b;
  for (const auto& spec : s.monitors) a.push_back(make_monitor<D>(spec, solver));
  // Saved between two samples: what a monitor accumulates after its last sample must be in the state too.
  while (solver.time() < save_at || solver.steps() % every != every / 2) {
    solver.step();
    for (auto& m : a) m->after_step(solver);
    if (solver.steps() % every == 0)
      for (auto& m : a) m->sample(solver);
  }

  std::stringstream checkpoint;
  StateWriter out(checkpoint);
  for (const auto& m : a) m->save_state(out);
  StateReader in(checkpoint);
  for (const auto& spec : s.monitors) b.push_back(make_monitor<D>(spec, solver));
  for (auto& m : b) m->load_state(in);
  EXPECT_EQ(checkpoint.peek(), std::char_traits<char>::eof()) << "each load reads what its save wrote, no more";

  std::vector<std::vector<std::vector<real>>> rows_a(a.size()), rows_b(b.size());
  while (solver.time() < s.duration) {
    solver.step();
    for (size_t k = 0; k < a.size(); ++k) a[k]->after_step(solver), b[k]->after_step(solver);
    if (solver.steps() % every != 0) continue;
    for (size_t k = 0; k < a.size(); ++k)
      rows_a[k].push_back(a[k]->sample(solver)), rows_b[k].push_back(b[k]->sample(solver));
  }
  std::vector<Summary> summaries;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_GT(rows_a[k].size(), 20u);
    EXPECT_EQ(rows_b[k], rows_a[k]) << a[k]->name();
    EXPECT_EQ(b[k]->summary(), a[k]->summary()) << a[k]->name();
    summaries.push_back(a[k]->summary());
  }
  return summaries;
}

real value_of(const Summary& sum, const std::string& key) {
  for (const auto& [k, v] : sum)
    if (k == key) return v;
  ADD_FAILURE() << "no summary value " << key;
  return 0;
}

constexpr real kSaveAt = 0.2;

}  // namespace

TEST(MonitorState, SectionResumesExactly) {
  // "near" cuts the release (more of it upstream at the start; by the save most of it has gone past, so a
  // resumed gauge that re-derived its orientation would count backwards); "dam", on a short window, has its
  // hydrograph's peak before the save and flow crossing at it; "far" sees the front after the save.
  const auto sum = expect_resumes_exactly<2>(
      dam_break_2d({{{"type", "section"}, {"name", "near"}, {"x", 0.22}},
                    {{"type", "section"}, {"name", "dam"}, {"x", 0.4}, {"window", 0.05}},
                    {{"type", "section"}, {"name", "far"}, {"x", 0.9}}}),
      kSaveAt);
  EXPECT_LT(value_of(sum[0], "arrival_time_s"), kSaveAt);
  EXPECT_LT(value_of(sum[1], "time_of_peak_s"), kSaveAt);
  EXPECT_GT(value_of(sum[2], "arrival_time_s"), kSaveAt);
}

TEST(MonitorState, SectionIn3DResumesExactly) {
  // A channel 0.4 m wide; the diagonal's orientation comes from the release's centroid, the short line leaves
  // particles beyond its ends whose side is remembered from before.
  const json scene = json::parse(R"({
    "dimensions": 3, "dp": 0.04, "duration": 0.5,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0}],
    "numerics": {"artificial_viscosity": 0.05, "speed_of_sound": 20},
    "fluid": [{"min": [0, 0, 0], "max": [0.2, 0.4, 0.3], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0, 0], "max": [1.2, 0.4, 0.4], "tag": "tank"}],
    "monitors": [{"type": "section", "name": "diagonal", "line": [[0.5, 0.0], [0.9, 0.4]]},
                 {"type": "section", "name": "short", "line": [[0.3, 0.1], [0.3, 0.3]]}]
  })");
  const auto sum = expect_resumes_exactly<3>(scene, kSaveAt, 8);
  EXPECT_GT(value_of(sum[0], "arrival_time_s"), kSaveAt);
  EXPECT_GT(value_of(sum[0], "volume_passed_m3"), 0.0);
}

TEST(MonitorState, StructureLoadResumesExactly) {
  // The surge hits "wall" after the save (the samples before it count in the late mean's 10%); "tank" (its floor
  // pushed down) is loaded throughout, its load cell's window spanning the save and its peak pressure before it;
  // the front hits "sill" before the save.
  const auto sum = expect_resumes_exactly<2>(
      dam_break_2d({{{"type", "structure_load"}, {"name", "wall"}, {"structure", "wall"}, {"normal", {1, 0}}},
                    {{"type", "structure_load"}, {"name", "tank"}, {"structure", "tank"}, {"normal", {0, -1}}},
                    {{"type", "structure_load"}, {"name", "sill"}, {"structure", "sill"}, {"normal", {1, 0}}}},
                   {{{"type", "block"}, {"min", {0.5, 0.0}}, {"max", {0.54, 0.04}}, {"tag", "sill"}}}),
      kSaveAt);
  EXPECT_GT(value_of(sum[0], "time_of_peak_force_s"), kSaveAt);
  EXPECT_GT(value_of(sum[0], "peak_force_n"), 0.0);
  EXPECT_LT(value_of(sum[1], "time_of_peak_pressure_s"), kSaveAt);
}

TEST(MonitorState, PressureProbeResumesExactly) {
  // "column" is wet from the first sample (its samples and their sum count from there), "wall" is wetted after the
  // save.
  const auto sum = expect_resumes_exactly<2>(
      dam_break_2d({{{"type", "pressure_probe"}, {"name", "column"}, {"point", {0.1, 0.05}}},
                    {{"type", "pressure_probe"}, {"name", "wall"}, {"point", {1.15, 0.05}}}}),
      kSaveAt);
  EXPECT_LT(value_of(sum[0], "arrival_time_s"), kSaveAt);
  EXPECT_GT(value_of(sum[1], "arrival_time_s"), kSaveAt);
}

TEST(MonitorState, DepthGaugeResumesExactly) {
  // "column" (a line over the release) reads its deepest at the start, away from the line's first station;
  // "reach" sees the surge after the save.
  const auto sum = expect_resumes_exactly<2>(
      dam_break_2d({{{"type", "depth_gauge"}, {"name", "column"}, {"line", {{0.3, 0.0}, {0.1, 0.0}}}},
                    {{"type", "depth_gauge"}, {"name", "reach"}, {"line", {{0.8, 0.0}, {1.1, 0.0}}}}}),
      kSaveAt);
  EXPECT_LT(value_of(sum[0], "time_of_max_depth_s"), kSaveAt);
  EXPECT_GT(value_of(sum[0], "station_of_max_depth_m"), 0.0);
  EXPECT_GT(value_of(sum[1], "time_of_max_depth_s"), kSaveAt);
}

TEST(MonitorState, AStateLoadsOnlyIntoItsOwnMonitor) {
  // A section's state refused by a structure load and by another section (its label names the monitor).
  const Scene s = parse_scene(
      dam_break_2d({{{"type", "section"}, {"name", "S1"}, {"x", 0.9}},
                    {{"type", "structure_load"}, {"name", "wall"}, {"structure", "wall"}, {"normal", {1, 0}}},
                    {{"type", "section"}, {"name", "S2"}, {"x", 0.9}}})
          .dump());
  Solver<2> solver(std::get<SceneSetup<2>>(s.setup));
  const auto section = make_monitor<2>(s.monitors[0], solver);
  std::stringstream checkpoint;
  StateWriter out(checkpoint);
  section->save_state(out);
  const std::string saved = checkpoint.str();
  for (size_t k : {1, 2}) {
    std::stringstream in_stream(saved);
    StateReader in(in_stream);
    EXPECT_THROW(make_monitor<2>(s.monitors[k], solver)->load_state(in), std::runtime_error) << s.monitors[k].name;
  }
}
