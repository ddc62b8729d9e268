// 3D dam break on a pillar (DualSPHysics CaseDambreak geometry, scenarios/validation/dam_break_3d.json):
// particle-steps per second at several resolutions, OpenMP scaling 1 -> N threads, and the cost of a
// friction-HBP step relative to a Newtonian one, and what switching artificial viscosity and density diffusion
// off saves.
//
//   build/bench/bench_dam_break_3d [--dp 0.016,0.012,0.0085] [--steps 200] [--warmup 20] [--threads 2] [--only-throughput]
//   build/bench/bench_dam_break_3d --dp 0.012 --skins 0,0.1,0.2,0.3,0.5   (the neighbour skin, side by side)
//
// Throughput counts fluid particles x steps (boundary particles do work only next to fluid); the total
// (fluid + boundary) figure is printed too, since some codes quote that.
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;

namespace {

struct Result {
  size_t fluid = 0, boundary = 0;
  double seconds = 0;
  long steps = 0;
  double fluid_rate() const { return fluid * steps / seconds; }
  double total_rate() const { return (fluid + boundary) * steps / seconds; }
};

Result measure(const json& scene_json, int threads, int warmup, int steps) {
  omp_set_num_threads(threads);
  Scene scene = parse_scene(scene_json.dump());
  auto& setup = std::get<SceneSetup<3>>(scene.setup);
  Solver<3> solver(setup);
  for (int i = 0; i < warmup; ++i) solver.step();
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < steps; ++i) solver.step();
  Result r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.steps = steps;
  r.fluid = solver.fluid().size();
  r.boundary = solver.boundary().size();
  return r;
}

// The Verlet list's skin (numerics.neighbour_skin): time per step against the first skin given (0: the cells
// scanned at every evaluation), with the scene's inviscid Verlet scheme (one evaluation a step) and with the catchment's
// friction-HBP and symplectic scheme (two), measured one after the other in this process.
void compare_skins(const json& base, double dp, const std::vector<double>& skins, int threads, int warmup, int steps) {
  const json hbp = {{"name", "water"}, {"rheology", "friction-hbp"}, {"density", 1000}, {"viscosity", 1e-3},
                    {"flow_index", 1.05}, {"regularisation", 100}, {"friction_angle", 28}, {"cohesion", 0}};
  std::printf("Neighbour skin at dp = %.4f m, %d threads, %d warm-up + %d timed steps (time per step relative to "
              "the first skin):\n", dp, threads, warmup, steps);
  for (bool symplectic_hbp : {false, true}) {
    double base_time = 0;
    for (double skin : skins) {
      json s = base;
      s["dp"] = dp;
      s["numerics"]["neighbour_skin"] = skin;
      if (symplectic_hbp) {
        s["materials"] = json::array({hbp});
        s["numerics"]["integrator"] = "symplectic";
      }
      const Result r = measure(s, threads, warmup, steps);
      if (base_time == 0) base_time = r.seconds;
      std::printf("  %-34s skin %.2f h: %10.3e fluid p-s/s   %.3fx\n",
                  symplectic_hbp ? "friction-HBP, symplectic" : "scene (inviscid water, Verlet)", skin,
                  r.fluid_rate(), r.seconds / base_time);
      std::fflush(stdout);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> dps = {0.016, 0.012, 0.0085};
  int steps = 200, warmup = 20, max_threads = omp_get_num_procs();
  bool only_throughput = false;
  CLI::App app{"3D dam break throughput (fluid particle-steps/s), OpenMP scaling, and the cost of rheologies and "
               "terms. Example: bench_dam_break_3d --dp 0.012 --steps 300 --only-throughput"};
  app.add_option("--dp", dps, "particle spacings [m], comma-separated")->delimiter(',');
  app.add_option("--steps", steps, "timed steps per measurement")->check(CLI::Range(1, 1000000));
  app.add_option("--warmup", warmup, "untimed steps first")->check(CLI::Range(0, 1000000));
  app.add_option("--threads", max_threads, "threads of the many-thread column")->check(CLI::Range(1, 1024));
  app.add_flag("--only-throughput", only_throughput, "the first table only (for side-by-side comparisons)");
  std::vector<double> skins;
  app.add_option("--skins", skins,
                 "only compare these neighbour skins [fractions of h] side by side at the first dp, comma-separated")
      ->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  std::ifstream in(std::string(RUNOUT_SOURCE_DIR) + "/scenarios/validation/dam_break_3d.json");
  json base = json::parse(in);
  if (!skins.empty()) {
    compare_skins(base, dps.front(), skins, max_threads, warmup, steps);
    return 0;
  }

  std::printf("3D dam break (Verlet, cubic spline, h = 1.732 dp, c0 = 34.3 m/s, CFL 0.2, DBC, alpha 0.1, "
              "Fourtakas 0.1); %d warm-up + %d timed steps\n\n", warmup, steps);
  std::printf("%8s %9s %9s %7s | %12s %12s | %12s %12s | %7s\n", "dp [m]", "fluid", "boundary", "threads",
              "fluid p-s/s", "total p-s/s", "1-thread", "speed-up", "eff.");
  for (double dp : dps) {
    json s = base;
    s["dp"] = dp;
    const Result one = measure(s, 1, warmup, steps);
    const Result many = measure(s, max_threads, warmup, steps);
    const double speedup = many.fluid_rate() / one.fluid_rate();
    std::printf("%8.4f %9zu %9zu %7d | %12.3e %12.3e | %12.3e %12.2f | %6.0f%%\n", dp, many.fluid, many.boundary,
                max_threads, many.fluid_rate(), many.total_rate(), one.fluid_rate(), speedup,
                100.0 * speedup / max_threads);
    std::fflush(stdout);
  }
  if (only_throughput) return 0;

  // Rheology cost: the same scene and step count, inviscid vs Newtonian (stress path) vs friction-HBP, all with
  // the symplectic integrator (the scene's Verlet cannot carry a yield-stress material: the parser refuses it).
  const double dp = dps.size() > 1 ? dps[1] : dps[0];
  std::printf("\nRheology cost at dp = %.4f m, %d threads, symplectic (time per step relative to Newtonian):\n", dp,
              max_threads);
  struct Case {
    const char* label;
    json material;
  };
  const std::vector<Case> cases = {
      {"inviscid (no stress term)", {{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0}}},
      {"newtonian mu = 1e-3", {{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 1e-3}}},
      {"friction-hbp phi = 28, m = 100, n = 1.05",
       {{"name", "water"}, {"rheology", "friction-hbp"}, {"density", 1000}, {"viscosity", 1e-3},
        {"flow_index", 1.05}, {"regularisation", 100}, {"friction_angle", 28}, {"cohesion", 0}}},
  };
  double newtonian_time = 0;
  std::vector<std::pair<const char*, Result>> results;
  for (const auto& c : cases) {
    json s = base;
    s["dp"] = dp;
    s["materials"] = json::array({c.material});
    s["numerics"]["integrator"] = "symplectic";
    results.push_back({c.label, measure(s, max_threads, warmup, steps)});
    if (std::string(c.label).rfind("newtonian", 0) == 0) newtonian_time = results.back().second.seconds;
  }
  for (const auto& [label, r] : results)
    std::printf("  %-42s %10.3e fluid p-s/s   %.2fx\n", label, r.fluid_rate(), r.seconds / newtonian_time);

  // Terms a scene switches off cost nothing: artificial viscosity and density diffusion off, one at a time
  // (inviscid water, same steps), time per step relative to the benchmark's own settings.
  std::printf("\nTerms switched off at dp = %.4f m, %d threads (time per step relative to alpha 0.1 + Fourtakas):\n", dp,
              max_threads);
  struct Terms {
    const char* label;
    double alpha;
    const char* diffusion;
  };
  const std::vector<Terms> terms = {{"alpha 0.1, Fourtakas 0.1 (benchmark)", 0.1, "fourtakas"},
                                    {"alpha 0 (no artificial viscosity)", 0.0, "fourtakas"},
                                    {"no density diffusion", 0.1, "none"},
                                    {"neither", 0.0, "none"}};
  double full_time = 0;
  for (const auto& t : terms) {
    json s = base;
    s["dp"] = dp;
    s["numerics"]["artificial_viscosity"] = t.alpha;
    s["numerics"]["density_diffusion"] = t.diffusion;
    const Result r = measure(s, max_threads, warmup, steps);
    if (full_time == 0) full_time = r.seconds;
    std::printf("  %-42s %10.3e fluid p-s/s   %.2fx\n", t.label, r.fluid_rate(), r.seconds / full_time);
  }
  return 0;
}
