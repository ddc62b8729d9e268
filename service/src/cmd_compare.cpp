// `runout compare`: the decision metrics (or every stored metric) of runs against a baseline, in per cent, as a
// table, CSV or JSON.
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <map>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/decision_metrics.hpp"
#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"

namespace runout::cli {
namespace {

using json = nlohmann::ordered_json;  // keys in the order written: metric, decision, baseline, values, percent

std::string fmt_value(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// The rows shown, in order: the decision metrics by rank (decision_metrics.hpp), then with `all` the rest by
// name; `filter` keeps names containing it, `differing` drops rows equal in every run. The outlet is found
// among every row, not only the filtered ones.
struct ShownRow {
  const Comparison::Row* row;
  bool decision;
};
std::vector<ShownRow> shown_rows(const Comparison& c, const CompareArgs& a) {
  std::vector<std::string> names;
  std::map<std::string, const Comparison::Row*> by_name;
  for (const auto& row : c.rows) names.push_back(row.metric), by_name[row.metric] = &row;
  const DecisionMetrics decision(names);
  std::vector<std::string> kept;
  for (const auto& n : names)
    if (a.filter.empty() || n.find(a.filter) != std::string::npos) kept.push_back(n);
  std::vector<ShownRow> out;
  for (const auto& n : decision.order(kept, a.all)) {
    const Comparison::Row* row = by_name.at(n);
    bool differs = false;
    for (size_t k = 0; k < row->values.size(); ++k)
      differs = differs || row->values[k] != row->baseline || row->never[k] != row->baseline_never;
    if (a.differing && !differs) continue;  // the same in every run (settings, particle counts)
    out.push_back({row, decision.is_decision(n)});
  }
  return out;
}

// A table of the rows against the baseline, with differences in per cent; a blank line after the decision
// metrics when others follow.
void print_table(const Comparison& c, const std::vector<ShownRow>& shown) {
  std::vector<std::string> header{"metric", c.baseline + " (base)"};
  for (const auto& r : c.runs) header.push_back(r);
  std::vector<std::vector<std::string>> rows;
  for (const auto& s : shown) {
    const auto& row = *s.row;
    std::vector<std::string> cells{row.metric, row.baseline_never ? "never" : row.baseline ? fmt_value(*row.baseline) : "-"};
    for (size_t k = 0; k < row.values.size(); ++k) {
      std::string cell = row.never[k] ? "never" : row.values[k] ? fmt_value(*row.values[k]) : "-";
      if (row.percent[k]) {
        char buf[32];
        std::snprintf(buf, sizeof buf, " (%+.1f%%)", *row.percent[k]);
        cell += buf;
      }
      cells.push_back(cell);
    }
    rows.push_back(cells);
  }
  std::vector<size_t> width(header.size());
  for (size_t k = 0; k < header.size(); ++k) width[k] = header[k].size();
  for (const auto& r : rows)
    for (size_t k = 0; k < r.size(); ++k) width[k] = std::max(width[k], r[k].size());
  auto line = [&](const std::vector<std::string>& cells) {
    for (size_t k = 0; k < cells.size(); ++k) std::printf(k == 0 ? "%-*s" : "  %*s", static_cast<int>(width[k]), cells[k].c_str());
    std::printf("\n");
  };
  line(header);
  for (size_t k = 0; k < rows.size(); ++k) {
    if (k > 0 && shown[k - 1].decision && !shown[k].decision) std::printf("\n");
    line(rows[k]);
  }
}

// A value as JSON writes it (shortest text that reads back the same double), or null.
json value_or_null(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

// One CSV field, quoted when it holds a separator, a quote or a line break (RFC 4180).
// (Built with push_back/append: GCC 12 warns falsely (-Wrestrict) on "\"" + string.)
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q(1, '"');
  for (char ch : s) {
    q.push_back(ch);
    if (ch == '"') q.push_back('"');
  }
  q.push_back('"');
  return q;
}

// metric, decision (1/0), the baseline's value, then each run's value and its difference in per cent; an
// empty field where a value is missing, "never" for an arrival that never happened (and no per cent). Numbers
// in full precision.
void print_csv(const Comparison& c, const std::vector<ShownRow>& shown) {
  auto num = [](const std::optional<double>& v) { return v ? json(*v).dump() : std::string(); };
  auto value = [&](const std::optional<double>& v, bool never) { return never ? std::string("never") : num(v); };
  std::string line = "metric,decision,";
  line.append(csv_field(c.baseline + " (baseline)"));
  for (const auto& r : c.runs) line.append(",").append(csv_field(r)).append(",").append(csv_field(r + " %"));
  std::printf("%s\n", line.c_str());
  for (const auto& s : shown) {
    line = csv_field(s.row->metric);
    line.append(s.decision ? ",1," : ",0,").append(value(s.row->baseline, s.row->baseline_never));
    for (size_t k = 0; k < s.row->values.size(); ++k)
      line.append(",").append(value(s.row->values[k], s.row->never[k])).append(",").append(num(s.row->percent[k]));
    std::printf("%s\n", line.c_str());
  }
}

// {baseline, baseline_id, runs, run_ids, outlet, rows: [{metric, decision, baseline, baseline_never, values[],
// never[], percent[]}]}: an arrival that never happened is null with its never flag true.
void print_json(const Comparison& c, int64_t base, const std::vector<ShownRow>& shown) {
  std::vector<std::string> names;
  for (const auto& row : c.rows) names.push_back(row.metric);
  json out = {{"baseline", c.baseline}, {"baseline_id", base},  {"runs", c.runs},
              {"run_ids", c.run_ids},   {"outlet", nullptr},    {"rows", json::array()}};
  if (const DecisionMetrics d(names); !d.outlet().empty()) out["outlet"] = d.outlet();
  for (const auto& s : shown) {
    json values = json::array(), percent = json::array();
    for (size_t k = 0; k < s.row->values.size(); ++k)
      values.push_back(value_or_null(s.row->values[k])), percent.push_back(value_or_null(s.row->percent[k]));
    out["rows"].push_back({{"metric", s.row->metric},
                           {"decision", s.decision},
                           {"baseline", value_or_null(s.row->baseline)},
                           {"baseline_never", s.row->baseline_never},
                           {"values", values},
                           {"never", s.row->never},
                           {"percent", percent}});
  }
  std::printf("%s\n", out.dump(2).c_str());
}

// The latest completed run of each variant of the sweep, the baseline's first; false (logged) when there is
// none or the baseline is not one of them.
bool sweep_runs(const RunStore& store, const CompareArgs& a, int64_t& base, std::vector<int64_t>& runs) {
  std::vector<std::string> order;  // variants in order of first appearance
  std::map<std::string, int64_t> latest;
  for (const auto& r : store.list_runs(a.sweep)) {
    if (r.status != "completed") continue;
    if (a.member >= 0) {  // one member of an ensemble: its layouts
      const auto m = split_member_name(r.variant);
      if (!m || m->member != a.member) continue;
    }
    if (!latest.count(r.variant)) order.push_back(r.variant);
    latest[r.variant] = r.id;
  }
  if (order.empty()) {
    if (a.member >= 0) spdlog::error("compare: no completed runs of member {} of sweep '{}' in {}", a.member, a.sweep, a.db);
    else spdlog::error("compare: no completed runs of sweep '{}' in {}", a.sweep, a.db);
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

std::string percent(double share) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%.0f %%", 100.0 * share);
  return buf;
}

// An ensemble's decision metrics as quantiles over its members, each layout's share of first places first.
void print_ensemble_table(const EnsembleSummary& s, const CompareArgs& a) {
  const DecisionMetrics d(s.metrics);
  std::printf("Ensemble %s: %zu members", s.sweep.c_str(), s.members);
  if (s.incomplete) std::printf(" (%zu more left out: not every layout completed)", s.incomplete);
  std::printf("\n");
  if (!s.ranking_metric.empty()) {
    std::printf("First (lowest %s) in", d.label(s.ranking_metric).c_str());
    for (const auto& l : s.layouts) std::printf(" %s %s%s", l.c_str(), percent(s.first_share.at(l)).c_str(), l == s.layouts.back() ? "" : ",");
    std::printf(" of %zu members\n", s.ranked_members);
  }
  std::printf("\n%-34s %-10s %10s %10s %10s %6s\n", "metric", "layout", "p10", "p50", "p90", "never");
  for (const auto& metric : s.metrics) {
    if (!a.filter.empty() && metric.find(a.filter) == std::string::npos) continue;
    for (const auto& l : s.layouts) {
      const auto q = s.quantiles.find(l);
      if (q == s.quantiles.end() || !q->second.count(metric)) continue;
      const MetricQuantiles& m = q->second.at(metric);
      const auto cell = [&](double v) { return m.count ? fmt_value(v) : std::string("-"); };
      std::printf("%-34s %-10s %10s %10s %10s %6zu\n", d.label(metric).c_str(), l.c_str(), cell(m.p10).c_str(),
                  cell(m.p50).c_str(), cell(m.p90).c_str(), m.never);
    }
  }
}

// metric, label, layout, p10, p50, p90, count, never, first_share (the layout's, on every row).
void print_ensemble_csv(const EnsembleSummary& s, const CompareArgs& a) {
  const DecisionMetrics d(s.metrics);
  std::printf("metric,label,layout,p10,p50,p90,count,never,first_share\n");
  for (const auto& metric : s.metrics) {
    if (!a.filter.empty() && metric.find(a.filter) == std::string::npos) continue;
    for (const auto& l : s.layouts) {
      const auto q = s.quantiles.find(l);
      if (q == s.quantiles.end() || !q->second.count(metric)) continue;
      const MetricQuantiles& m = q->second.at(metric);
      const auto num = [&](double v) { return m.count ? json(v).dump() : std::string(); };
      std::printf("%s,%s,%s,%s,%s,%s,%zu,%zu,%s\n", csv_field(metric).c_str(), csv_field(d.label(metric)).c_str(),
                  csv_field(l).c_str(), num(m.p10).c_str(), num(m.p50).c_str(), num(m.p90).c_str(), m.count, m.never,
                  json(s.first_share.at(l)).dump().c_str());
    }
  }
}

}  // namespace

int compare(const CompareArgs& a) {
  if (!std::filesystem::exists(a.db)) {  // RunStore would create an empty store at a mistyped path
    spdlog::error("compare: --db: no run store at {}", a.db);
    return 2;
  }
  try {
    RunStore store(a.db);
    std::vector<int64_t> runs = a.ids;
    int64_t base = 0;
    if (runs.empty()) {
      if (a.sweep.empty()) {
        spdlog::error("compare: name a --sweep or give --runs");
        return 2;
      }
      if (a.member < 0)
        if (const auto ensemble = summarise_ensemble(store, a.sweep)) {
          if (a.format == "csv") print_ensemble_csv(*ensemble, a);
          else if (a.format == "json") std::printf("%s\n", ensemble_summary_json(*ensemble).c_str());
          else print_ensemble_table(*ensemble, a);
          return 0;
        }
      if (!sweep_runs(store, a, base, runs)) return 2;
    } else {
      base = runs.front();
      if (!a.baseline.empty()) {
        const char* end = a.baseline.data() + a.baseline.size();
        if (std::from_chars(a.baseline.data(), end, base).ptr != end) {
          spdlog::error("compare: --baseline '{}' must be a run id with --runs", a.baseline);
          return 2;
        }
      }
      runs.erase(std::remove(runs.begin(), runs.end(), base), runs.end());
    }
    const Comparison c = compare_runs(store, runs, base);
    const auto shown = shown_rows(c, a);
    if (!a.all && shown.empty())  // on stderr: csv and json stay parseable
      spdlog::info("compare: no decision metric{} in these runs; --all lists every stored metric",
                   a.filter.empty() ? "" : " matching --filter");
    if (a.format == "csv") print_csv(c, shown);
    else if (a.format == "json") print_json(c, base, shown);
    else print_table(c, shown);
  } catch (const std::exception& e) {
    spdlog::error("compare: {}", e.what());
    return 2;
  }
  return 0;
}

Action add_compare(CLI::App& app) {
  auto a = std::make_shared<CompareArgs>();
  auto* cmd = app.add_subcommand(
      "compare", "Print the decision metrics (or every stored metric) of runs against a baseline, in per cent");
  cmd->footer("Example (after runout sweep scenarios/flume/c0_c7.json --fidelity draft):\n"
              "  runout compare --sweep flume-C0-C7 --format csv > c0_c7.csv");
  cmd->add_option("--sweep", a->sweep, "Compare the latest completed run of each variant of this sweep");
  cmd->add_option("--baseline", a->baseline, "Baseline variant (default: the first by name, C0 / G0) or run id");
  cmd->add_option("--runs", a->ids, "Run ids instead of a sweep (the first is the baseline)");
  cmd->add_option("--member", a->member,
                  "An ensemble sweep: compare the layouts of this member (default: every layout's quantiles over the "
                  "members and how often it ranks first)")
      ->check(CLI::Range(0, 1 << 20));
  cmd->add_option("--format", a->format, "table | csv | json")
      ->check(CLI::IsMember({"table", "csv", "json"}))
      ->capture_default_str();
  cmd->add_flag("--all", a->all, "Every stored metric: the decision metrics first, then the rest by name");
  cmd->add_flag("--differing", a->differing, "Only rows whose value is not the same in every run");
  cmd->add_option("--filter", a->filter, "Only metrics whose name contains this");
  cmd->add_option("--db", a->db, "Run store (SQLite)")->capture_default_str();
  return [a](const char*) { return compare(*a); };
}

}  // namespace runout::cli
