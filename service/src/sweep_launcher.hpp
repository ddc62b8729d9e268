#pragma once
// A sweep of the service handed to an MPI launch command configured by the operator (docs/service.md,
// "Sweeps on a cluster"): RUNOUT_SWEEP_LAUNCHER, for instance
//
//   srun -n {ranks} {runout} sweep {sweep} --db {db} --out {out}
//   mpirun -np {ranks} {runout} sweep {sweep} --db {db} --out {out}
//
// POST /sweeps then writes a sweep file (the base scene and the layouts its jobs were resolved from), starts
// the command (`/bin/sh -c`, its own process group, output to RUNS/service/sweep-<id>/launcher.log) and
// follows it: the sweep's jobs start `running` (no in-process worker claims them) and each becomes `done`
// when its run appears completed in the run store under the job's manifest hash, which `runout sweep`
// computes the same way. When the command ends, a job without a completed run is `failed` with the exit
// status and the log's path. A cancelled job is marked at once (its run may still be stored); the command is
// stopped when every job of its sweep is cancelled. Server shutdown stops the commands (SIGTERM to the group)
// and puts their unfinished jobs back in the queue, where the next start's in-process workers take them.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "jobs.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout::service {

struct LaunchedSweep {
  int64_t sweep_id = 0;
  std::string name;       // the sweep's name (runs.sweep in the store)
  std::string base_json;  // the base scene the jobs were resolved from
  std::vector<SweepVariant> variants;  // the layouts
  std::optional<std::string> ensemble_json;  // the sweep's ensemble: the file carries it, mpi_sweep expands it
  std::string fidelity = "standard";  // draft | standard | fine | custom
  std::optional<double> dp;           // custom
};

class SweepLauncher {
 public:
  // Throws std::invalid_argument naming RUNOUT_SWEEP_LAUNCHER / RUNOUT_SWEEP_RANKS when the template lacks
  // {sweep} or {db}, has an unknown {placeholder}, or ranks is outside [1, 100000].
  SweepLauncher(std::string command_template, int ranks, std::filesystem::path db, std::filesystem::path runs_dir,
                std::filesystem::path scene_dir, JobQueue& queue);
  ~SweepLauncher();  // stop()
  SweepLauncher(const SweepLauncher&) = delete;
  SweepLauncher& operator=(const SweepLauncher&) = delete;

  // RUNS/service/sweep-<id>/runs: the --out of the command ({out}), under which the jobs' outputs land.
  std::filesystem::path out_root(int64_t sweep_id) const;
  // Writes the files and starts the command in a thread of its own that follows it until it ends.
  void launch(const LaunchedSweep& sweep);
  // SIGTERM to every running command's process group (SIGKILL 15 s later), waits for the followers.
  void stop();

  // The command line with the placeholders replaced (each value single-quoted for the shell).
  std::string command_for(const std::filesystem::path& sweep_file, const std::optional<double>& dp) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace runout::service
