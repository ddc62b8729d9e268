#pragma once
// The `runout` subcommands, one file each (cmd_<name>.cpp). Each adds its subcommand and options to the CLI11
// app, binding them to state of its own, and returns what runs it; main.cpp walks kCommands and runs the
// action of the one parsed.
#include <atomic>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "runout/scenarios/sweep.hpp"

namespace runout::cli {

// argv[0]: `serve` finds the web page next to the binary through it when /proc/self/exe is not readable.
using Action = std::function<int(const char* argv0)>;

struct Command {
  const char* name;
  Action (*add)(CLI::App& app);
};

Action add_run(CLI::App& app);
Action add_sweep(CLI::App& app);
Action add_compare(CLI::App& app);
Action add_report(CLI::App& app);
Action add_serve(CLI::App& app);
Action add_tradeoff(CLI::App& app);
Action add_calibrate(CLI::App& app);
Action add_calibrate_material(CLI::App& app);
Action add_study(CLI::App& app);
Action add_schema(CLI::App& app);

// In the order `runout --help` lists them.
inline const Command kCommands[] = {{"run", add_run},           {"sweep", add_sweep},
                                    {"compare", add_compare},   {"report", add_report},
                                    {"study", add_study},
                                    {"serve", add_serve},
                                    {"tradeoff", add_tradeoff}, {"calibrate", add_calibrate},
                                    {"calibrate-material", add_calibrate_material},
                                    {"schema", add_schema}};

// Set by SIGINT/SIGTERM once stop_on_signals() ran: runs, sweeps and the server stop at their next check.
extern std::atomic<bool> g_stop;
void stop_on_signals();

// A file's whole text; throws SceneError ("(file)", cannot read PATH) if it cannot be read.
std::string read_text(const std::filesystem::path& p);

// `--fidelity draft|standard|fine` or `--dp DP` (mutually exclusive), as `run` and `sweep` take them; the
// scene or sweep is then resolved by scenarios' resolve_scene / resolve_variant.
struct FidelityArgs {
  std::string name;
  double dp = 0;
  // `default_text` says what runs without either ("the sweep's", "the scene as written").
  void add_to(CLI::App* cmd, const std::string& default_text);
  std::optional<Fidelity> chosen() const;  // nullopt: neither option given
};

// `runout compare`'s table; `runout sweep` prints it at the end.
struct CompareArgs {
  std::string db = "runout.db", sweep, baseline, filter, format = "table";
  std::vector<int64_t> ids;
  bool all = false, differing = false;
  int member = -1;  // an ensemble sweep: compare this member's layouts; -1: the ensemble's quantiles
};
int compare(const CompareArgs& a);

}  // namespace runout::cli
