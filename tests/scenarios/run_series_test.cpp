// A run's series folder holds what this run wrote and nothing older: a rerun into the same output folder with
// other monitors must not leave the earlier monitors' files behind for a reader to take as this run's.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

Scene tank_with_gauge(const std::string& gauge) {
  const json s = {{"name", "series-tank"},
                  {"dimensions", 2},
                  {"dp", 0.02},
                  {"duration", 0.02},
                  {"materials", {{{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0.001}}}},
                  {"fluid", {{{"min", {0.0, 0.0}}, {"max", {0.2, 0.1}}, {"material", "water"}}}},
                  {"boundaries", {{{"type", "tank"}, {"min", {0.0, 0.0}}, {"max", {0.4, 0.3}}}}},
                  {"monitors", {{{"type", "depth_gauge"}, {"name", gauge}, {"point", {0.1, 0.0}}}}},
                  {"output", {{"series_interval", 0.01}}}};
  return parse_scene(s.dump());
}

}  // namespace

TEST(RunSeries, ARerunIntoTheSameFolderLeavesNoEarlierMonitorsFile) {
  const fs::path out = fs::temp_directory_path() / "runout-run-series-test";
  fs::remove_all(out);
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = 1;
  ASSERT_EQ(run_scene(tank_with_gauge("first"), opt).status, "completed");
  ASSERT_TRUE(fs::exists(out / "series" / "depth_gauge_first.csv"));
  ASSERT_EQ(run_scene(tank_with_gauge("second"), opt).status, "completed");
  EXPECT_TRUE(fs::exists(out / "series" / "depth_gauge_second.csv"));
  EXPECT_FALSE(fs::exists(out / "series" / "depth_gauge_first.csv")) << "the first run's gauge outlived it";
  EXPECT_TRUE(fs::exists(out / "series" / "run.csv"));
  fs::remove_all(out);
}
