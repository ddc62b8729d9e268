#pragma once
// Running a sweep and storing what it measures: every variant of a sweep is resolved at a fidelity, run
// (several at once with --jobs), and its metrics and series are put in the run store under the run's
// manifest hash. A variant whose manifest is already stored as completed is not run again, so an
// interrupted sweep resumes where it stopped. The CLI (`runout sweep`) and the HTTP service share this.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout {

// Every series/*.csv under a run directory, keyed by file stem ("run", "section_S1").
std::map<std::string, std::string> read_series(const std::filesystem::path& run_dir);

// The record of a finished run (its metrics and series from out_dir), as the store keeps it; sweep and variant
// empty (a single run).
RunStore::RunRecord run_record(const Manifest& manifest, const std::string& scene, const std::string& fidelity,
                               const RunSummary& summary, const std::filesystem::path& out_dir);

// Runs one resolved scene (JSON text) to `out_dir` and stores it; returns the stored run's id and status.
// A completed run with the same manifest already in the store is returned as it is (reused = true).
struct StoredRun {
  int64_t run_id = 0;
  std::string status;  // completed | failed | stopped
  std::string error;
  bool reused = false;
  double wall_seconds = 0;
};
struct StoreRunOptions {
  std::string sweep, variant;
  Fidelity fidelity;
  RunOptions run;  // out_dir, threads, progress, stop
};
StoredRun run_and_store(RunStore& store, const std::string& resolved_json, const std::filesystem::path& base_dir,
                        const StoreRunOptions& options);
// The same on a parsed scene: the text above is parsed once, here, for the manifest and the build alike.
StoredRun run_and_store(RunStore& store, const nlohmann::json& resolved, const std::filesystem::path& base_dir,
                        const StoreRunOptions& options);

// run_and_store in its two halves, so that a run can execute in one process (an MPI worker rank) and be stored
// by another (rank 0, which owns the store), with exactly the record run_and_store would have stored.
// The stored completed run with this manifest hash, if any (reused = true).
std::optional<StoredRun> find_completed_run(const RunStore& store, const std::string& manifest_hash);
// Parses and runs the resolved scene to options.run.out_dir (removed first) and returns the record to store;
// `result` gets the status, error and wall time (run_id stays 0). Nothing is stored. Throws what parse_scene
// and run_scene throw (a refused scene, a run that could not start).
RunStore::RunRecord execute_run(const std::string& resolved_json, const Manifest& manifest,
                                const std::filesystem::path& base_dir, const StoreRunOptions& options,
                                StoredRun& result);
RunStore::RunRecord execute_run(const nlohmann::json& resolved, const Manifest& manifest,
                                const std::filesystem::path& base_dir, const StoreRunOptions& options,
                                StoredRun& result);

struct SweepEvent {
  enum Kind { started, progress, finished } kind;
  std::string variant;
  size_t index = 0, total = 0;  // the variant's position in the sweep, and the sweep's size
  RunProgress progress_info;    // kind == progress
  StoredRun result;             // kind == finished
};

struct SweepOptions {
  std::filesystem::path out_root = "runs";  // a run's outputs go to out_root/<sweep>/<variant>
  Fidelity fidelity;                        // overrides the sweep's when fidelity_override
  bool fidelity_override = false;
  int jobs = 1;     // runs at once
  int threads = 0;  // OpenMP threads per run; 0: the cores divided among the jobs
  double checkpoint_interval = 0;  // [s] wall time between a run's checkpoints (RunOptions); 0: none
  const std::atomic<bool>* stop = nullptr;
  std::function<void(const SweepEvent&)> on_event;  // called from worker threads, one call at a time
};

struct SweepResult {
  std::vector<std::string> variants;
  std::vector<StoredRun> runs;  // one per variant, in the sweep's order (status "not run" if stopped first)
  // Variants given difference rasters against the baseline (write_difference_rasters).
  std::vector<std::string> differences;
  // Layouts given exceedance maps (an ensemble sweep, write_ensemble_outputs).
  std::vector<std::string> exceedance;
};

// Runs the sweep's layouts (resumable through the store), then writes the difference rasters and, for an
// ensemble, its exceedance maps and summary (ensemble_summary.hpp).
SweepResult run_sweep(RunStore& store, const Sweep& sweep, const SweepOptions& options);

// Per sweep: for each variant after the first (the baseline layout: C0, G0), SWEEP_DIR/<variant>/rasters/
// diff_max_depth.tif and diff_max_hv.tif = the variant's raster minus the baseline's, on the union of their
// windows (a cell outside one counts as 0 there), with a diverging QGIS style. A variant whose rasters or
// the baseline's are not in SWEEP_DIR (not run here) is skipped. Returns the variants written.
std::vector<std::string> write_difference_rasters(const std::filesystem::path& sweep_dir,
                                                  const std::vector<std::string>& variants);
// The same for every group of a sweep that shares a baseline: the whole sweep, or, in an ensemble, each member's
// layouts against that member's first layout (the baseline at the same material and volume).
std::vector<std::string> write_sweep_differences(const std::filesystem::path& sweep_dir, const Sweep& sweep);

// One layout's difference rasters against the baseline's, as write_difference_rasters writes them, where the
// runs' folders are not laid out as SWEEP_DIR/<variant> (the service's jobs): RASTERS/<name>.tif minus
// BASE_RASTERS/<name>.tif into OUT_RASTERS/diff_<name>.tif and .qml. False when a raster is missing.
bool write_layout_differences(const std::filesystem::path& rasters, const std::string& variant,
                              const std::filesystem::path& base_rasters, const std::string& baseline,
                              const std::filesystem::path& out_rasters);

}  // namespace runout
