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
  CLI11_PARSE(app, argc, argv);
  for (size_t k = 0; k < actions.size(); ++k)
    if (app.got_subcommand(runout::cli::kCommands[k].name)) return actions[k](argv[0]);
  return 0;
}
