// The C0-C7 study on the shipped flume (scenarios/flume/), at the sweep's draft fidelity: the orderings the
// study found (SPEC.md, "The scenario sets"; thesis section 4.5) must hold in our runs.
//   - the peak force on a check dam at P2 (C3) exceeds that at P1 (C2): the flow accelerates down the chute;
//   - a deposition area ahead of the P2 dam (C6) lowers that peak below C3;
//   - a check dam cuts the outlet's peak discharge below C0;
//   - a retention basin shrinks the inundated area and the runout below C0, the higher wall (C5) more than C4;
//   - on the C1 layout, friction-HBP leaves a thicker, shorter deposit than plain HBP tuned to the same
//     arrival time.
// One test runs the whole sweep once (gtest_discover_tests runs each TEST in its own process, so splitting it
// would run the sweep again per finding); each finding is its own EXPECT with the numbers in its message.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kFlume = fs::path(RUNOUT_SOURCE_DIR) / "scenarios/flume";

struct TempDir {
  fs::path path = fs::temp_directory_path() / "runout-flume-study";
  TempDir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

}  // namespace

TEST(FlumeStudy, DraftSweepShowsTheStudysOrderings) {
  TempDir tmp;
  RunStore store(tmp.path / "runout.db");
  const Sweep sweep = load_sweep(kFlume / "c0_c7.json");
  SweepOptions opt;
  opt.out_root = tmp.path / "runs";
  opt.jobs = 2;  // small runs: two at once, one thread each, use two cores better than one run on both
  opt.threads = 1;
  opt.on_event = [](const SweepEvent& e) {
    if (e.kind == SweepEvent::finished)
      std::printf("%s: %s in %.1f s\n", e.variant.c_str(), e.result.status.c_str(), e.result.wall_seconds);
  };
  const SweepResult r = run_sweep(store, sweep, opt);
  ASSERT_EQ(r.runs.size(), 8u);
  std::map<std::string, std::map<std::string, double>> m;
  for (size_t k = 0; k < r.runs.size(); ++k) {
    ASSERT_EQ(r.runs[k].status, "completed") << r.variants[k] << ": " << r.runs[k].error;
    m[r.variants[k]] = store.metrics(r.runs[k].run_id);
    EXPECT_EQ(m[r.variants[k]].at("leaks"), 0) << r.variants[k];
  }
  auto at = [&](const std::string& variant, const std::string& metric) {
    const auto& mv = m.at(variant);
    const auto it = mv.find(metric);
    if (it == mv.end()) ADD_FAILURE() << variant << " has no metric " << metric;
    return it == mv.end() ? 0.0 : it->second;
  };
  const std::string force_p1 = "monitors.structure_load.CD_P1.peak_force_n";
  const std::string force_p2 = "monitors.structure_load.CD_P2.peak_force_n";
  const std::string outlet_q = "monitors.section.Outlet.peak_discharge_m3_s";
  const std::string area = "terrain.inundation.inundated_area_m2";
  const std::string runout = "terrain.inundation.runout_m";

  // Mass is conserved and the flow reaches the plain: in C0 most of the release passes the outlet.
  const double released = at("C0", "terrain.release_volume_m3");
  EXPECT_GT(at("C0", "monitors.section.Outlet.volume_passed_m3"), 0.5 * released);

  EXPECT_GT(at("C3", force_p2), at("C2", force_p1)) << "peak force on the dam at P2 vs at P1";
  EXPECT_LT(at("C6", force_p2), at("C3", force_p2)) << "deposition area ahead of the P2 dam";
  EXPECT_LT(at("C3", outlet_q), at("C0", outlet_q)) << "check dam at P2 vs nothing, outlet peak discharge";
  EXPECT_LT(at("C2", outlet_q), at("C0", outlet_q)) << "check dam at P1 vs nothing, outlet peak discharge";
  EXPECT_LT(at("C4", area), at("C0", area)) << "basin, inundated area";
  EXPECT_LT(at("C4", runout), at("C0", runout)) << "basin, runout";
  EXPECT_LT(at("C5", area), at("C4", area)) << "higher basin wall, inundated area";
  EXPECT_LT(at("C5", runout), at("C4", runout)) << "higher basin wall, runout";

  // Friction-HBP against plain HBP "tuned to the same arrival time" (SPEC.md) on the C1 layout: a constant
  // tau_y chosen once so that the plain-HBP front reaches the Outlet when the friction-HBP one does (found by
  // runs at 200-900 Pa, docs/study.md; the literal 1.3 kPa of the thesis' table stops on our 38 degree chute,
  // see there). The tuning is checked here (within 10 %) before the deposits are compared.
  constexpr double kTunedYieldStress = 750.0;  // Pa; 700 Pa arrives 10 % early, 800 Pa 12 % late
  json hbp = json::parse(resolve_variant(sweep.base_json, sweep.variants.at(1), sweep.fidelity));
  auto& mat = hbp["materials"][0];
  mat["rheology"] = "hbp";
  mat["yield_stress"] = kTunedYieldStress;
  mat.erase("friction_angle");
  mat.erase("cohesion");
  StoreRunOptions o;
  o.sweep = "flume-hbp";
  o.variant = "C1-hbp";
  o.fidelity = sweep.fidelity;
  o.run.out_dir = tmp.path / "runs/C1-hbp";
  const StoredRun plain = run_and_store(store, hbp.dump(), kFlume, o);
  ASSERT_EQ(plain.status, "completed") << plain.error;
  const auto h = store.metrics(plain.run_id);
  const std::string t0 = "monitors.section.Outlet.arrival_time_s";
  ASSERT_NEAR(h.at(t0), at("C1", t0), 0.1 * at("C1", t0)) << "plain HBP not tuned to the same arrival time";
  EXPECT_GT(at("C1", "terrain.inundation.deposit_max_depth_m"), h.at("terrain.inundation.deposit_max_depth_m"))
      << "friction-HBP deposit thicker than plain HBP";
  EXPECT_LT(at("C1", runout), h.at(runout)) << "friction-HBP runout shorter than plain HBP";

  // The table, for docs/study.md.
  for (const auto& [variant, mv] : m)
    std::printf("%s: F_P1 %.2f N, F_P2 %.2f N, Q_out %.4f m3/s, area %.3f m2, runout %.3f m, deposit %.4f m\n",
                variant.c_str(), mv.count(force_p1) ? mv.at(force_p1) : -1.0,
                mv.count(force_p2) ? mv.at(force_p2) : -1.0, mv.at(outlet_q), mv.at(area), mv.at(runout),
                mv.at("terrain.inundation.deposit_max_depth_m"));
  std::printf("C1-hbp: t_0 %.3f s (C1 %.3f s), area %.3f m2, runout %.3f m, deposit %.4f m\n", h.at(t0),
              at("C1", t0), h.at(area), h.at(runout), h.at("terrain.inundation.deposit_max_depth_m"));
}
