// The `runout` command: the subcommands of commands.hpp, one file each.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"

int main(int argc, char** argv) {
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
