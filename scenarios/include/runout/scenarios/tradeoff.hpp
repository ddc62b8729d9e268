#pragma once
// Speed against accuracy (`runout tradeoff`, docs/tradeoff.md): one scene run at a ladder of particle
// spacings, plus optional numerics choices (kernel, integrator, CFL) at one rung, each run stored like a
// sweep's run (sweep "tradeoff:<name>", variant = the level's label) so a repeated ladder reuses what is
// stored. Each level's cost (particles, steps, wall time, particle-steps/s, peak memory, the cost model's
// prediction) and the deviation of every result metric from the finest level, with the observed order of
// convergence, are reported as a table, two CSV files and an SVG plot.
#include <atomic>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout {

struct TradeoffSpec {
  std::string name;                  // stored as sweep "tradeoff:<name>"
  std::string base_json;             // the scene (or a sweep's base scene)
  std::filesystem::path base_dir;    // relative file names (terrain.dem) resolve here
  SweepVariant variant;              // structures built (label unused)
  std::vector<std::string> levels;   // preset names (draft, standard, fine) or dp values in metres
  // Numerics choices run at one rung: "numerics.kernel=cubic" (a JSON path in the scene, '=' a value:
  // JSON if it parses, else a string).
  std::vector<std::string> options;
  std::string option_level;          // the rung they run at (a level as given); default the coarsest
};

struct TradeoffRunOptions {
  std::filesystem::path out_dir = "runs/tradeoff";  // a level's outputs go to OUT/<label>
  int threads = 0;                                    // OpenMP threads (0: all cores)
  double checkpoint_interval = 0;  // [s] wall time between a level's checkpoints (RunOptions); 0: none
  const std::atomic<bool>* stop = nullptr;
  bool predict_only = false;                          // build each level and predict its cost; run nothing
  std::function<void(const std::string&)> on_line;    // progress lines for people
};

struct TradeoffLevel {
  std::string label;           // "dp=0.05" or "dp=0.05 numerics.kernel=cubic"
  double dp = 0;
  std::string option;          // empty on the ladder
  int64_t run_id = 0;
  std::string status;          // completed | failed | stopped | not run
  bool reused = false;         // already in the store
  double fluid = 0, boundary = 0, steps = 0, wall_seconds = 0, particle_steps_per_s = 0, peak_memory_mb = 0;
  double build_seconds = 0;  // building the scene (DEM, corridor, particles), before the run's wall time
  double boundary_peak = 0;   // wall particles alive at most at once (measured)
  double predicted_steps = 0, predicted_seconds = 0;  // the cost model, before the run
  double predicted_fluid_peak = 0, predicted_boundary_peak = 0;  // particles at most at once, predicted
  std::map<std::string, double> metrics;              // flattened, as stored
};

struct TradeoffMetric {
  std::string name;
  double finest = 0;
  std::vector<std::optional<double>> deviation_percent;  // per level (nullopt: missing, or the finest is 0)
  std::optional<double> order;                           // observed order of convergence on the three finest rungs
  std::optional<double> dp_within_5, dp_within_10;       // coarsest dp from which every finer rung is within
};

struct TradeoffResult {
  std::vector<TradeoffLevel> levels;  // the ladder from coarse to fine, then the options
  std::vector<TradeoffMetric> metrics;
};

// Resolves every level (refusing a bad level or option with SceneError naming it) before running anything.
TradeoffResult run_tradeoff(RunStore& store, const TradeoffSpec& spec, const TradeoffRunOptions& options);

// The result metrics compared across levels: monitors (sections, structure loads), inundation, protected
// zones, retained volumes, front position. Settings, particle counts and run statistics are not results.
bool is_result_metric(const std::string& flattened_name);

// Fills result.metrics from the levels' metrics (the finest ladder rung is the reference).
void analyse_tradeoff(TradeoffResult& result);

// Observed order p from three rungs dp1 > dp2 > dp3 with values f1, f2, f3 (Roache's generalised
// Richardson): (f1 - f2) / (f2 - f3) = (dp1^p - dp2^p) / (dp2^p - dp3^p), solved for p in [0.05, 8];
// nullopt when the differences change sign (oscillatory) or no p in range fits.
std::optional<double> observed_order(double dp1, double f1, double dp2, double f2, double dp3, double f3);

std::string format_tradeoff(const TradeoffResult& result);
void write_tradeoff_csv(const TradeoffResult& result, const std::filesystem::path& dir);  // levels.csv, metrics.csv
void write_tradeoff_svg(const TradeoffResult& result, const std::filesystem::path& file, const std::string& title);

}  // namespace runout
