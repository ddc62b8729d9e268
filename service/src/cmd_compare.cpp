// `runout compare`: every stored metric of runs against a baseline, in per cent.
#include <algorithm>
#include <cstdio>
#include <map>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"

namespace runout::cli {
namespace {

std::string fmt_value(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// The table's cells: a row per metric that differs between the runs (all of them with `all`).
std::vector<std::vector<std::string>> comparison_rows(const Comparison& c, const std::string& filter, bool all) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& row : c.rows) {
    if (!filter.empty() && row.metric.find(filter) == std::string::npos) continue;
    bool differs = false;
    for (const auto& v : row.values) differs = differs || v != row.baseline;
    if (!all && !differs) continue;  // the same in every run (settings, particle counts): not a difference
    std::vector<std::string> cells{row.metric, row.baseline ? fmt_value(*row.baseline) : "-"};
    for (size_t k = 0; k < row.values.size(); ++k) {
      std::string cell = row.values[k] ? fmt_value(*row.values[k]) : "-";
      if (row.percent[k]) {
        char buf[32];
        std::snprintf(buf, sizeof buf, " (%+.1f%%)", *row.percent[k]);
        cell += buf;
      }
      cells.push_back(cell);
    }
    rows.push_back(cells);
  }
  return rows;
}

// A table of every stored metric of the runs against the baseline, with differences in per cent.
void print_comparison(const Comparison& c, const std::string& filter, bool all) {
  std::vector<std::string> header{"metric", c.baseline + " (base)"};
  for (const auto& r : c.runs) header.push_back(r);
  const auto rows = comparison_rows(c, filter, all);
  std::vector<size_t> width(header.size());
  for (size_t k = 0; k < header.size(); ++k) width[k] = header[k].size();
  for (const auto& r : rows)
    for (size_t k = 0; k < r.size(); ++k) width[k] = std::max(width[k], r[k].size());
  auto line = [&](const std::vector<std::string>& cells) {
    for (size_t k = 0; k < cells.size(); ++k) {
      std::printf(k == 0 ? "%-*s" : "  %*s", static_cast<int>(width[k]), cells[k].c_str());
    }
    std::printf("\n");
  };
  line(header);
  for (const auto& r : rows) line(r);
}

// The latest completed run of each variant of the sweep, the baseline's first; false (logged) when there is
// none or the baseline is not one of them.
bool sweep_runs(const RunStore& store, const CompareArgs& a, int64_t& base, std::vector<int64_t>& runs) {
  std::vector<std::string> order;  // variants in order of first appearance
  std::map<std::string, int64_t> latest;
  for (const auto& r : store.list_runs(a.sweep)) {
    if (r.status != "completed") continue;
    if (!latest.count(r.variant)) order.push_back(r.variant);
    latest[r.variant] = r.id;
  }
  if (order.empty()) {
    spdlog::error("compare: no completed runs of sweep '{}' in {}", a.sweep, a.db);
    return false;
  }
  std::sort(order.begin(), order.end());
  const std::string base_name = a.baseline.empty() ? order.front() : a.baseline;
  if (!latest.count(base_name)) {
    spdlog::error("compare: --baseline '{}' is not a completed variant of sweep '{}'", base_name, a.sweep);
    return false;
  }
  base = latest[base_name];
  for (const auto& v : order)
    if (v != base_name) runs.push_back(latest[v]);
  return true;
}

}  // namespace

int compare(const CompareArgs& a) {
  try {
    RunStore store(a.db);
    std::vector<int64_t> runs = a.ids;
    int64_t base = 0;
    if (runs.empty()) {
      if (a.sweep.empty()) {
        spdlog::error("compare: name a --sweep or give --runs");
        return 2;
      }
      if (!sweep_runs(store, a, base, runs)) return 2;
    } else {
      base = runs.front();
      if (!a.baseline.empty()) base = std::stoll(a.baseline);
      runs.erase(std::remove(runs.begin(), runs.end(), base), runs.end());
    }
    print_comparison(compare_runs(store, runs, base), a.filter, a.all);
  } catch (const std::exception& e) {
    spdlog::error("compare: {}", e.what());
    return 2;
  }
  return 0;
}

Action add_compare(CLI::App& app) {
  auto a = std::make_shared<CompareArgs>();
  auto* cmd = app.add_subcommand("compare", "Print every stored metric of runs against a baseline, in per cent");
  cmd->add_option("--sweep", a->sweep, "Compare the latest completed run of each variant of this sweep");
  cmd->add_option("--baseline", a->baseline, "Baseline variant (default: the first by name, C0 / G0) or run id");
  cmd->add_option("--runs", a->ids, "Run ids instead of a sweep (the first is the baseline)");
  cmd->add_option("--filter", a->filter, "Only metrics whose name contains this");
  cmd->add_flag("--all", a->all, "Also rows that are the same in every run");
  cmd->add_option("--db", a->db, "Run store (SQLite)")->capture_default_str();
  return [a](const char*) { return compare(*a); };
}

}  // namespace runout::cli
