#pragma once
// Runs a scene to its end time and writes the run's outputs:
//   OUT/metrics.json            run statistics, mass balance, energy, front, resolved settings, status
//   OUT/series/run.csv          t, dt, kinetic energy, potential energy released, max speed, front, mass
//   OUT/series/final_surface.csv  x, surface height of the fluid at the end (binned at dp)
//   OUT/checkpoint.bin          the state a stopped or killed run resumes from (RunOptions::checkpoint_interval)
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
  // When set, the run's OpenMP threads follow it, read again about every 0.25 s of wall time (a ThreadShare's
  // lease: the cores divided among the runs going at once); `threads` is then ignored.
  std::function<int()> threads_now;
  std::function<void(const RunProgress&)> on_progress;  // called about every 0.25 s of wall time
  const std::atomic<bool>* stop = nullptr;              // set to stop early (the run is marked "stopped")
  // Checkpoints (docs/design.md, "Checkpoints"): with an interval > 0 the run saves its whole state to
  // OUT/checkpoint.bin every checkpoint_interval seconds of wall time and when it is stopped, and a run whose
  // OUT holds a checkpoint of the same scene resumes from it; the file is removed once the run ends. A
  // checkpoint of another scene there is refused (std::runtime_error): nothing is overwritten.
  double checkpoint_interval = 0;  // [s] wall time; 0: none
};

struct RunSummary {
  std::string status;  // "completed", "failed" or "stopped"
  std::string error;
  long steps = 0;
  real simulated_time = 0;
  double wall_seconds = 0;
  double particle_steps_per_second = 0;
  real ended_at_rest = -1;   // [s] when the flow had been at rest output.rest_time (the run ended); -1: never
  real resumed_from = -1;    // [s] the simulated time of the checkpoint the run resumed from; -1: none
  std::string metrics_json;  // what metrics.json holds
};

RunSummary run_scene(const Scene& scene, const RunOptions& options);

// True when out_dir holds a checkpoint of this scene (run_scene would resume from it).
bool has_checkpoint_of(const Scene& scene, const std::filesystem::path& out_dir);

// Final surface height per x-bin of width dp: the top of the highest fluid particle (+dp/2) in the bin,
// taken over all y in 3D. Bins without fluid are left out.
template <int D>
std::vector<std::pair<real, real>> surface_profile(const ParticleArrays<D>& fluid, real dp);

}  // namespace runout
