#pragma once
// Runs a scene to its end time and writes the run's outputs:
//   OUT/metrics.json            run statistics, mass balance, energy, front, resolved settings, status
//   OUT/series/run.csv          t, dt, kinetic energy, potential energy released, max speed, front, mass
//   OUT/series/final_surface.csv  x, surface height of the fluid at the end (binned at dp)
//   OUT/snapshots/              particle snapshots (when asked) for ParaView: frames, walls, DEM, snapshots.pvd
//                               (vtk_output.hpp)
#include <atomic>
#include <filesystem>
#include <functional>
#include <string>

#include "runout/scenarios/scene.hpp"

namespace runout {

struct RunProgress {
  real time = 0, duration = 0;
  long steps = 0;
  double wall_seconds = 0;
  size_t particles = 0;
};

struct RunOptions {
  std::filesystem::path out_dir;
  bool snapshots = false;
  int threads = 0;  // 0: OpenMP default
  std::function<void(const RunProgress&)> on_progress;  // called about every 0.25 s of wall time
  const std::atomic<bool>* stop = nullptr;              // set to stop early (the run is marked "stopped")
};

struct RunSummary {
  std::string status;  // "completed", "failed" or "stopped"
  std::string error;
  long steps = 0;
  real simulated_time = 0;
  double wall_seconds = 0;
  double particle_steps_per_second = 0;
  real ended_at_rest = -1;   // [s] when the flow had been at rest output.rest_time (the run ended); -1: never
  std::string metrics_json;  // what metrics.json holds
};

RunSummary run_scene(const Scene& scene, const RunOptions& options);

// Final surface height per x-bin of width dp: the top of the highest fluid particle (+dp/2) in the bin,
// taken over all y in 3D. Bins without fluid are left out.
template <int D>
std::vector<std::pair<real, real>> surface_profile(const ParticleArrays<D>& fluid, real dp);

}  // namespace runout
