// Corridor benchmark: the same release on the Jacksboro DEM and on that DEM padded to 10x its area (mirrored
// copies around it, so the padding is real-looking terrain, not nodata). A run's particles and cost per
// step must not grow with DEM area outside the corridor.
//
//   build/bench/bench_corridor [--steps 200] [--threads 2] [--dp 1.0]
//
// Prints, per DEM: its cells, the scene build time, modelled fraction, particles (flow; wall particles described
// and the most alive at once), and ms per step.
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

// Reflect index k into [0, n).
int reflect(int k, int n) {
  const int period = 2 * n;
  k = ((k % period) + period) % period;
  return k < n ? k : period - 1 - k;
}

struct Row {
  size_t cells = 0, fluid = 0, boundary = 0, alive = 0;
  double build_s = 0, ms_per_step = 0, fraction = 0;
};

Row measure(json scene, const std::string& dem, int steps, int threads) {
  scene["terrain"]["dem"] = dem;
  scene["terrain"].erase("resolution");  // the DEM files below are already at 10 m in UTM 16N
  scene["terrain"].erase("crs");
  omp_set_num_threads(threads);
  Row r;
  const auto t0 = std::chrono::steady_clock::now();
  Scene s = parse_scene(scene.dump());
  r.build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cells = s.terrain->dem->values.size();
  r.fraction = s.terrain->modelled_fraction;
  Solver<3> solver(std::get<SceneSetup<3>>(s.setup));
  r.fluid = solver.fluid().size();
  r.boundary = solver.boundary_described();
  for (int k = 0; k < 20; ++k) solver.step();
  const auto t1 = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) solver.step();
  r.alive = solver.boundary_peak();
  r.ms_per_step = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count() / steps;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  int steps = 200, threads = 2;
  double dp = 1.0;
  for (int k = 1; k + 1 < argc; k += 2) {
    if (!std::strcmp(argv[k], "--steps")) steps = std::atoi(argv[k + 1]);
    if (!std::strcmp(argv[k], "--threads")) threads = std::atoi(argv[k + 1]);
    if (!std::strcmp(argv[k], "--dp")) dp = std::atof(argv[k + 1]);
  }
  const fs::path src = RUNOUT_SOURCE_DIR;
  std::ifstream in(src / "scenarios/terrain/jacksboro_slope.json");
  std::stringstream ss;
  ss << in.rdbuf();
  json scene = json::parse(ss.str());
  scene["dp"] = dp;

  terrain::DemOptions opt;
  opt.target_crs = "EPSG:32616";
  opt.resolution = 10.0;
  const terrain::Grid dem = terrain::load_dem((src / "scenarios/dem/jacksboro_fault_dem.vrt").string(), opt);
  // Padded: sqrt(10) times wider and taller, the original in the middle, mirrored copies around it.
  const double f = std::sqrt(10.0);
  const int nx = static_cast<int>(std::lround(dem.nx * f)), ny = static_cast<int>(std::lround(dem.ny * f));
  const int ox = (nx - dem.nx) / 2, oy = (ny - dem.ny) / 2;
  terrain::Grid big(nx, ny, dem.x0 - ox * dem.dx, dem.y0 + oy * dem.dy, dem.dx, dem.dy, dem.crs_wkt);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) big.at(i, j) = dem.at(reflect(i - ox, dem.nx), reflect(j - oy, dem.ny));
  const fs::path tmp = fs::temp_directory_path() / "runout-bench-corridor";
  fs::create_directories(tmp);
  terrain::write_geotiff((tmp / "dem.tif").string(), dem);
  terrain::write_geotiff((tmp / "padded.tif").string(), big);

  std::printf("corridor benchmark: jacksboro_slope release, dp = %.2f m, %d steps, %d threads\n", dp, steps, threads);
  std::printf("%-10s %12s %10s %12s %8s %10s %10s %10s\n", "DEM", "cells", "build_s", "modelled", "fluid", "boundary",
              "alive", "ms/step");
  const Row a = measure(scene, (tmp / "dem.tif").string(), steps, threads);
  const Row b = measure(scene, (tmp / "padded.tif").string(), steps, threads);
  for (const auto& [name, r] : {std::pair{"original", a}, std::pair{"padded10x", b}})
    std::printf("%-10s %12zu %10.2f %12.3g %8zu %10zu %10zu %10.2f\n", name, r.cells, r.build_s, r.fraction, r.fluid,
                r.boundary, r.alive, r.ms_per_step);
  std::printf("area ratio %.2f, particle ratio %.4f, cost-per-step ratio %.3f\n",
              static_cast<double>(b.cells) / a.cells, static_cast<double>(b.fluid + b.boundary) / (a.fluid + a.boundary),
              b.ms_per_step / a.ms_per_step);
  fs::remove_all(tmp);
  return 0;
}
