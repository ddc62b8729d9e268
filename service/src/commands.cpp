// What the subcommands share (commands.hpp).
#include "commands.hpp"

#include <csignal>
#include <fstream>
#include <sstream>

#include "runout/scenarios/scene.hpp"

namespace runout::cli {

std::atomic<bool> g_stop{false};

namespace {
extern "C" void on_signal(int) { g_stop.store(true); }
}  // namespace

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw SceneError("(file)", "cannot read " + p.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void FidelityArgs::add_to(CLI::App* cmd, const std::string& default_text) {
  auto* f = cmd->add_option("--fidelity", name, "draft | standard | fine | screening (default: " + default_text + ")")
                ->check(CLI::IsMember(fidelity_names()));
  auto* d = cmd->add_option("--dp", dp, "Explicit particle spacing [m] instead of a preset")->check(CLI::Range(1e-4, 1e3));
  f->excludes(d);  // CLI11 refuses both: "--fidelity excludes --dp" (exit 2, main.cpp)
}

std::optional<Fidelity> FidelityArgs::chosen() const {
  if (name.empty() && dp <= 0) return std::nullopt;
  Fidelity f;
  f.name = name.empty() ? "custom" : name;
  if (dp > 0) f.dp = dp;
  return f;
}

void stop_on_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

}  // namespace runout::cli
