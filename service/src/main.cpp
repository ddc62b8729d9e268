// The `runout` command: the subcommands of commands.hpp, one file each.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <cstdlib>

#include "commands.hpp"

namespace {

// OpenMP's threads spin at a barrier before they sleep (libgomp: 300 000 spins), so a team that shares the cores
// with another process waits out whole time slices of a descheduled thread: a two-thread 2D dam break took over
// 13 minutes beside a one-thread run instead of 25 s (2026-12-06, docs/performance.md "Runs that share a
// machine"). libgomp reads OMP_WAIT_POLICY once, when it is loaded, so the command sets it to passive and starts
// itself again, unless the user has chosen a policy (OMP_WAIT_POLICY or GOMP_SPINCOUNT).
void wait_passively(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") || std::getenv("GOMP_SPINCOUNT")) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);  // returns only on failure: then the run goes on with OpenMP's default
  unsetenv("OMP_WAIT_POLICY");
}

}  // namespace

int main(int argc, char** argv) {
  wait_passively(argv);
  spdlog::set_default_logger(spdlog::stderr_color_mt("runout"));  // messages on stderr, like the progress bar
  CLI::App app{"Runout: debris-flow hazard-mitigation design studies with SPH"};
  app.set_version_flag("--version", std::string(RUNOUT_VERSION));
  app.require_subcommand(1);
  std::vector<runout::cli::Action> actions;
  for (const auto& c : runout::cli::kCommands) actions.push_back(c.add(app));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version are "errors" with exit code 0; a usage error is exit 2, as a refused scene is
    // (CLI11's own codes, 105-109, would say nothing to a script).
    return app.exit(e) == 0 ? 0 : 2;
  }
  for (size_t k = 0; k < actions.size(); ++k)
    if (app.got_subcommand(runout::cli::kCommands[k].name)) return actions[k](argv[0]);
  return 0;
}
