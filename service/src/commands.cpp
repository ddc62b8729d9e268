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

void stop_on_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

}  // namespace runout::cli
