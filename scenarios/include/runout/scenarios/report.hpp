#pragma once
// A study report (`runout report`, GET /sweeps/{id}/report.html): one self-contained HTML file (inline CSS,
// charts as inline SVG, maps as base64 PNG; nothing fetched when it is opened) that puts the layouts of a sweep
// side by side: a ranking table of the decision metrics (decision_metrics.hpp) first, ranked by the outlet's
// peak discharge, then hydrographs per section and loads per structure (one line per layout), a map per layout
// with its depth legend and scale bar, the fidelity and what the stored tradeoff ladders say of each decision
// metric's convergence, and each run's manifest. docs/report.md.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/store.hpp"

namespace runout {

struct ReportRun {
  int64_t run_id = 0;
  std::string label;                // the layout ("C3"); empty: the stored variant
  std::filesystem::path out_dir;    // the run's output folder (maps); empty or missing: no map
  // The folder whose rasters/ holds the sweep's difference rasters of this layout (diff_*.tif), where it is not
  // out_dir (a service job that reused another job's run); empty: out_dir.
  std::filesystem::path differences_dir;
};

struct StudyReportInput {
  std::string title;                // the sweep's name
  std::vector<ReportRun> runs;      // every layout, the baseline among them
  int64_t baseline_id = 0;          // one of runs' run_id
  // An ensemble sweep: what its members say of each layout (shown first: quantiles, first places, exceedance
  // maps from exceedance_dirs[layout] = SWEEP_DIR/<layout>/exceedance); `runs` are then the layouts of one
  // member, `member`.
  std::optional<EnsembleSummary> ensemble;
  int member = -1;
  std::map<std::string, std::filesystem::path> exceedance_dirs;
};

// The report's HTML. Throws std::runtime_error when a run is not in the store, std::invalid_argument when the
// baseline is not one of the runs or there are none.
std::string study_report_html(const RunStore& store, const StudyReportInput& input);

// The latest completed run of each variant of the stored sweep `sweep` (variants in natural order), the
// baseline the variant named `baseline` (empty: the first, C0 / G0), each run's outputs in
// runs_root/<sweep>/<variant> as `runout sweep --out runs_root` wrote them. For an ensemble sweep
// (ensemble_summary.hpp): its summary, and the layouts of member `member` (-1: the first member with every
// layout completed), labelled by layout, `baseline` naming a layout. Throws std::invalid_argument naming
// --sweep, --baseline or --member when the sweep has no completed run, the baseline is not one of its
// variants, or the member has no completed run.
StudyReportInput sweep_report_input(const RunStore& store, const std::string& sweep, const std::string& baseline,
                                    const std::filesystem::path& runs_root, int member = -1);

// sweep_report_input, then the HTML written to out_path (through a temporary file, renamed when complete).
// Throws std::invalid_argument naming --runs when runs_root/<sweep> is not a folder (a mistyped path).
void write_study_report(const RunStore& store, const std::string& sweep, const std::string& baseline,
                        const std::filesystem::path& runs_root, const std::filesystem::path& out_path,
                        int member = -1);

// Text made safe inside HTML elements and quoted attributes: & < > " ' as character references.
std::string html_escape(const std::string& text);

}  // namespace runout
