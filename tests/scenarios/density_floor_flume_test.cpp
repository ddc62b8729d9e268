// The flume's C6 layout (deposition area at P1, check dam at P2) at dp = 0.04 m blew up near its end
// (t = 3.41-3.48 s of 3.5: a particle with a non-finite position) because the cohesionless material's
// continuity density drifted far under rho0 (docs/tradeoff.md, "Density floor"). With
// numerics.density_floor it runs to the end with exact mass and no leak.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

TEST(DensityFloorFlume, C6AtFourCentimetresRunsToTheEnd) {
  const fs::path flume = fs::path(RUNOUT_SOURCE_DIR) / "scenarios/flume";
  const Sweep sweep = load_sweep(flume / "c0_c7.json");
  const SweepVariant* c6 = nullptr;
  for (const auto& v : sweep.variants)
    if (v.name == "C6") c6 = &v;
  ASSERT_NE(c6, nullptr);
  Fidelity fid;
  fid.name = "custom";
  fid.dp = 0.04;
  json scene = json::parse(resolve_variant(sweep.base_json, *c6, fid));
  scene["numerics"]["density_floor"] = true;
  RunOptions opt;
  opt.out_dir = fs::temp_directory_path() / "runout-density-floor-c6";
  fs::remove_all(opt.out_dir);
  const RunSummary r = run_scene(parse_scene(scene.dump(), flume), opt);
  const json m = json::parse(r.metrics_json);
  ASSERT_EQ(r.status, "completed") << r.error;
  EXPECT_NEAR(m["simulated_time_s"].get<double>(), 3.5, 0.01);
  EXPECT_EQ(m["leaks"], 0);
  EXPECT_LT(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
  EXPECT_TRUE(m["settings"]["density_floor"].get<bool>());
  fs::remove_all(opt.out_dir);
}
