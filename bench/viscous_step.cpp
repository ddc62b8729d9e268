// The implicit viscous step against the explicit cap, side by side on one scene (docs/performance.md,
// "Implicit viscous step"): the Bui et al. (2008) column collapse of scenarios/validation/column_collapse_2d.json
// run to its end with numerics.viscosity implicit (the default) and explicit at cap factors 1 and 20 (the factor
// that brought the explicit step within 10 % of the experiment's wall height), alternating, best of --repeat.
// Prints steps, wall time, steps and fluid particle-steps per second, steps per simulated second, the CG
// iterations per solve and the deposit's extent at 1 cm depth and wall height.
//
//   build/bench/bench_viscous_step [--duration 1.5] [--repeat 1] [--threads 1] [--factors 1,20]
#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

struct Result {
  double wall = std::numeric_limits<double>::infinity();
  long steps = 0;
  double particles = 0, iterations = 0, extent = 0, wall_height = 0;
};

// Where the final surface (x, h per bin) last falls to 1 cm, and its first bin's height.
void deposit(const fs::path& out, Result& r) {
  std::ifstream in(out / "series" / "final_surface.csv");
  std::string line;
  std::getline(in, line);
  std::vector<std::pair<double, double>> s;
  double x, h;
  char comma;
  while (in >> x >> comma >> h) s.push_back({x, h});
  if (s.empty()) return;
  r.wall_height = s.front().second;
  for (size_t i = s.size(); i-- > 1;)
    if (s[i - 1].second >= 0.01 && s[i].second < 0.01) {
      r.extent = s[i - 1].first + (s[i - 1].second - 0.01) / (s[i - 1].second - s[i].second) * (s[i].first - s[i - 1].first);
      return;
    }
}

Result run_once(const json& scene_json, const fs::path& out) {
  const Scene scene = parse_scene(scene_json.dump());
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = omp_get_max_threads();
  const RunSummary sum = run_scene(scene, opt);
  Result r;
  r.wall = sum.wall_seconds;
  r.steps = sum.steps;
  const json m = json::parse(sum.metrics_json);
  r.particles = m["particles"]["fluid_initial"].get<double>();
  if (m.contains("viscous_solves")) r.iterations = m["viscous_solves"]["iterations_mean"].get<double>();
  deposit(out, r);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The implicit viscous step against the explicit cap on the Bui column collapse"};
  double duration = 1.5;
  int repeat = 1, threads = 1;
  std::vector<double> factors = {1, 20};
  app.add_option("--duration", duration, "simulated seconds");
  app.add_option("--repeat", repeat, "runs of each setting (best kept)");
  app.add_option("--threads", threads, "OpenMP threads");
  app.add_option("--factors", factors, "explicit cap factors")->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  omp_set_num_threads(threads);
  std::ifstream in(fs::path(RUNOUT_SOURCE_DIR) / "scenarios" / "validation" / "column_collapse_2d.json");
  const json base = json::parse(in);
  std::vector<std::pair<std::string, json>> settings;
  json imp = base;
  imp["duration"] = duration;
  settings.push_back({"implicit", imp});
  for (double f : factors) {
    json e = imp;
    e["numerics"]["viscosity"] = "explicit";
    e["numerics"]["viscosity_cap_factor"] = f;
    settings.push_back({"explicit x" + std::to_string(static_cast<int>(f)), e});
  }
  std::vector<Result> best(settings.size());
  const fs::path out = fs::temp_directory_path() / "runout-bench-viscous-step";
  for (int k = 0; k < repeat; ++k)
    for (size_t s = 0; s < settings.size(); ++s) {
      const Result r = run_once(settings[s].second, out / std::to_string(s));
      if (r.wall < best[s].wall) best[s] = r;
    }
  std::printf("Bui column collapse, %.2f s simulated, %d thread(s), best of %d (experiment: extent 0.368 m, wall 0.099 m)\n",
              duration, threads, repeat);
  std::printf("%-12s %8s %9s %10s %14s %12s %10s %9s %9s\n", "setting", "steps", "wall [s]", "steps/s",
              "particle-st/s", "steps/sim-s", "CG it/sv", "extent", "wall h");
  for (size_t s = 0; s < settings.size(); ++s) {
    const Result& r = best[s];
    std::printf("%-12s %8ld %9.2f %10.0f %14.3g %12.0f %10.1f %9.3f %9.4f\n", settings[s].first.c_str(), r.steps, r.wall,
                r.steps / r.wall, r.steps * r.particles / r.wall, r.steps / duration, r.iterations, r.extent,
                r.wall_height);
  }
  return 0;
}
