// `runout report`: a sweep's study report, one self-contained HTML file (scenarios/report.hpp, docs/report.md).
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/report.hpp"
#include "runout/scenarios/store.hpp"

namespace runout::cli {
namespace {

struct ReportArgs {
  std::string sweep, baseline, db = "runout.db", runs = "runs", out = "report.html";
  int member = -1;
};

int report(const ReportArgs& a) {
  if (!std::filesystem::exists(a.db)) {  // RunStore would create an empty file
    spdlog::error("report: --db: no run store at {}", a.db);
    return 2;
  }
  try {
    RunStore store(a.db);
    write_study_report(store, a.sweep, a.baseline, a.runs, a.out, a.member);
  } catch (const std::invalid_argument& e) {
    spdlog::error("report: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("report: {}", e.what());
    return 1;
  }
  spdlog::info("report: wrote {}", a.out);
  return 0;
}

}  // namespace

Action add_report(CLI::App& app) {
  auto a = std::make_shared<ReportArgs>();
  auto* cmd = app.add_subcommand("report", "Write a sweep's study report: one self-contained HTML file");
  cmd->footer("Example (after runout sweep scenarios/flume/c0_c7.json --fidelity draft):\n"
              "  runout report --sweep flume-C0-C7 --out flume-report.html");
  cmd->add_option("--sweep", a->sweep, "The stored sweep (its latest completed run of each variant)")->required();
  cmd->add_option("--baseline", a->baseline, "Baseline variant (default: the first by name, C0 / G0)");
  cmd->add_option("--member", a->member,
                  "An ensemble sweep: the member whose runs the report shows in detail (default: the first with every "
                  "layout completed)")
      ->check(CLI::Range(0, 1 << 20));
  cmd->add_option("--db", a->db, "Run store (SQLite)")->capture_default_str();
  cmd->add_option("--runs", a->runs, "Where runout sweep --out wrote the runs (their maps: RUNS/<sweep>/<variant>)")
      ->capture_default_str();
  cmd->add_option("--out", a->out, "The HTML file to write")->capture_default_str();
  return [a](const char*) { return report(*a); };
}

}  // namespace runout::cli
