// Catchment wall benchmark: the Jacksboro G7 layout (scenarios/catchment/jacksboro_g.json, all three dams) at
// one dp, with the bed's wall particles laid near the flow (terrain.walls = near_flow, the default) or the whole
// bed from the start (all). Run each mode in its own process, side by side, for the peak memory:
//
//   build/bench/bench_catchment_walls --dp 2 --seconds 10 --threads 2 --walls near_flow
//   build/bench/bench_catchment_walls --dp 2 --seconds 10 --threads 2 --walls all
//
// Prints the scene build time, flow particles, wall particles the scene describes and the most alive at once
// (and per flow particle), steps, ms per step, fluid particle-steps/s and the process's peak resident memory.
#include <omp.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  double dp = 2.0, seconds = 10.0;
  int threads = 2;
  std::string walls = "near_flow";
  CLI::App app{"Jacksboro G7: wall particles alive, cost per step and memory, bed near the flow or whole"};
  app.add_option("--dp", dp, "particle spacing [m]")->check(CLI::Range(0.5, 20.0));
  app.add_option("--seconds", seconds, "simulated time to run [s]")->check(CLI::Range(0.01, 1000.0));
  app.add_option("--threads", threads, "OpenMP threads")->check(CLI::Range(1, 1024));
  app.add_option("--walls", walls, "terrain.walls")->check(CLI::IsMember({"near_flow", "all"}));
  CLI11_PARSE(app, argc, argv);

  const fs::path scene_path = fs::path(RUNOUT_SOURCE_DIR) / "scenarios/catchment/jacksboro_g.json";
  std::ifstream in(scene_path);
  std::stringstream ss;
  ss << in.rdbuf();
  json j = json::parse(ss.str());
  j["dp"] = dp;
  j.erase("fidelity");
  j["terrain"]["walls"] = walls;
  omp_set_num_threads(threads);

  const auto t0 = std::chrono::steady_clock::now();
  Scene scene = parse_scene(j.dump(), scene_path.parent_path());
  Solver<3> solver(std::get<SceneSetup<3>>(scene.setup));
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const size_t fluid = solver.fluid().size();
  const auto t1 = std::chrono::steady_clock::now();
  double particle_steps = 0;
  while (solver.time() < seconds) {
    particle_steps += static_cast<double>(solver.fluid().size());
    solver.step();
  }
  const double run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);

  std::printf("catchment walls: Jacksboro G7, dp = %.2f m, %.3g s simulated, %d threads, walls = %s\n", dp, seconds,
              threads, walls.c_str());
  std::printf("%8s %8s %12s %12s %9s %8s %9s %12s %8s\n", "build_s", "fluid", "described", "alive_peak",
              "per_flow", "steps", "ms/step", "fluid_ps/s", "rss_MB");
  std::printf("%8.2f %8zu %12llu %12zu %9.1f %8ld %9.3f %12.4g %8.0f\n", build_s, fluid,
              static_cast<unsigned long long>(solver.boundary_described()), solver.boundary_peak(),
              static_cast<double>(solver.boundary_peak()) / static_cast<double>(fluid), solver.steps(),
              1e3 * run_s / static_cast<double>(solver.steps()), particle_steps / run_s, usage.ru_maxrss / 1024.0);
  return 0;
}
