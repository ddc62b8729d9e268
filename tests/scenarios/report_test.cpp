// The study report: a sweep of three flume layouts (C0, C2, C4 at dp = 10 cm: about three seconds), its HTML
// read back: the ranking table lists the layouts in the order of their stored outlet Q_m with the stored
// values, the page fetches nothing (every image a data: URI), each section and structure has its chart, each
// terrain run its map with a scale bar, text is escaped, and a stored tradeoff ladder is read for convergence.
#include <gtest/gtest.h>

#include <cstdio>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>

#include <nlohmann/json.hpp>

#include "runout/scenarios/report.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const std::string kQm = "monitors.section.Outlet.peak_discharge_m3_s";

struct Fixture {
  // One folder per test: ctest -j runs a file's tests as separate processes at once.
  fs::path dir = fs::temp_directory_path() /
                 ("runout-report-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  std::unique_ptr<RunStore> store;
  SweepResult result;
  Fixture() {
    fs::remove_all(dir);
    fs::create_directories(dir);
    const json sweep = {{"name", "report-test"},
                        {"base", (fs::path(RUNOUT_SOURCE_DIR) / "scenarios/flume/flume.json").string()},
                        {"variants",
                         {{{"name", "C0"}, {"structures", json::array()}},
                          {{"name", "C2"}, {"structures", {"CD_P1"}}},
                          {{"name", "C4"}, {"structures", {"RB1_P2"}}}}}};
    std::ofstream(dir / "sweep.json") << sweep.dump();
    store = std::make_unique<RunStore>(dir / "runout.db");
    SweepOptions o;
    o.out_root = dir / "runs";
    o.fidelity_override = true;
    o.fidelity = Fidelity{"custom", 0.1};
    o.jobs = 2;
    result = run_sweep(*store, load_sweep(dir / "sweep.json"), o);
  }
  ~Fixture() { fs::remove_all(dir); }
};

Fixture& fixture() {
  static Fixture f;  // one sweep for every test
  return f;
}

std::string report_html(const std::string& baseline = "") {
  Fixture& f = fixture();
  const fs::path out = f.dir / "report.html";
  write_study_report(*f.store, "report-test", baseline, f.dir / "runs", out);
  std::ifstream in(out);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The text between the first `from` and the next `to` after it (empty when absent).
std::string between(const std::string& s, const std::string& from, const std::string& to) {
  const size_t a = s.find(from);
  if (a == std::string::npos) return "";
  const size_t b = s.find(to, a + from.size());
  return s.substr(a + from.size(), b == std::string::npos ? std::string::npos : b - a - from.size());
}

std::vector<std::string> all(const std::string& s, const std::regex& re, int group = 1) {
  std::vector<std::string> out;
  for (std::sregex_iterator it(s.begin(), s.end(), re), end; it != end; ++it) out.push_back((*it)[group].str());
  return out;
}

}  // namespace

TEST(Report, RankingTableListsTheLayoutsByTheirStoredOutletDischargeWithTheStoredValues) {
  Fixture& f = fixture();
  ASSERT_EQ(f.result.runs.size(), 3u);
  for (const auto& r : f.result.runs) ASSERT_EQ(r.status, "completed") << r.error;
  const std::string html = report_html();
  const std::string table = between(html, "<table id=\"ranking\"", "</table>");
  ASSERT_FALSE(table.empty());
  const std::string body = between(table, "<tbody>", "</tbody>");
  const auto rows = all(body, std::regex("<tr[^>]*>(.*?)</tr>"));
  ASSERT_EQ(rows.size(), 3u);

  // The stored Q_m of each layout, and the order the table must follow: lowest first, ties (values that print
  // the same at the table's 4 significant digits, docs/report.md) by name.
  std::map<std::string, int64_t> id_of;
  for (const auto& r : f.store->list_runs("report-test")) id_of[r.variant] = r.id;
  auto printed = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return std::stod(buf);
  };
  std::vector<std::string> expected = {"C0", "C2", "C4"};
  std::stable_sort(expected.begin(), expected.end(), [&](const std::string& a, const std::string& b) {
    return printed(f.store->metrics(id_of[a]).at(kQm)) < printed(f.store->metrics(id_of[b]).at(kQm));
  });
  ASSERT_NE(expected.front(), "C0") << "a structure lowers the outlet's Q_m, so the baseline does not rank first";
  const std::regex layout_cell("<th scope=\"row\"><a href=\"#layout-([^\"]+)\">");
  const std::regex qm_cell("data-metric=\"" + std::regex_replace(kQm, std::regex("\\."), "\\.") + "\" data-value=\"([^\"]+)\"");
  std::vector<std::string> listed;
  for (const auto& row : rows) {
    std::smatch m;
    ASSERT_TRUE(std::regex_search(row, m, layout_cell)) << row.substr(0, 300);
    listed.push_back(m[1]);
    std::smatch v;
    ASSERT_TRUE(std::regex_search(row, v, qm_cell)) << row.substr(0, 300);
    EXPECT_EQ(std::stod(v[1].str()), f.store->metrics(id_of[m[1]]).at(kQm)) << m[1];  // exactly the stored value
  }
  EXPECT_EQ(listed, expected);
  // The ranking key is said, and the table comes before every chart.
  EXPECT_NE(html.find("Ranked by the outlet's peak discharge Q_m"), std::string::npos);
  EXPECT_LT(html.find("<table id=\"ranking\""), html.find("<svg class=\"chart\""));
  // Every decision metric of C2 is in its row: its check dam's load and retained volume among them.
  const std::string c2 = *std::find_if(rows.begin(), rows.end(), [](const auto& r) { return r.find("#layout-C2") != std::string::npos; });
  const auto c2_metrics = f.store->metrics(id_of["C2"]);
  for (const std::string name : {"monitors.structure_load.CD_P1.peak_force_n", "terrain.inundation.runout_m"}) {
    ASSERT_TRUE(c2_metrics.count(name)) << name;
    EXPECT_NE(c2.find("data-metric=\"" + name + "\" data-value=\"" + json(c2_metrics.at(name)).dump() + "\""),
              std::string::npos)
        << name;
  }
}

TEST(Report, IsSelfContainedWithAChartPerSectionAndStructureAndAMapPerLayout) {
  const std::string html = report_html();
  const auto srcs = all(html, std::regex("<img[^>]* src=\"([^\"]*)\""));
  EXPECT_EQ(all(html, std::regex("<img alt=\"maximum flow depth of ")).size(), 3u) << "one depth map per terrain layout";
  for (const auto& s : srcs) EXPECT_EQ(s.rfind("data:image/png;base64,iVBORw0KGgo", 0), 0u) << s.substr(0, 60);  // a PNG
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(html.find("src=\"/"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  // A hydrograph per section with a line per layout; a load chart per structure with a line per layout building it.
  for (const auto& [monitor, lines] : std::vector<std::pair<std::string, size_t>>{{"Chute", 3}, {"Outlet", 3}, {"CD_P1", 1}, {"RB1_P2", 1}}) {
    const std::string fig = between(html, "<figure class=\"chart\" data-monitor=\"" + monitor + "\">", "</figure>");
    ASSERT_NE(fig.find("<svg"), std::string::npos) << monitor;
    EXPECT_EQ(all(fig, std::regex("<polyline class=\"series\"")).size(), lines) << monitor;
  }
  // Each map has a scale bar of a round length shorter than the flume (6 m), and the depth legend in metres.
  const auto bars = all(html, std::regex("class=\"scalebar\" data-metres=\"([^\"]+)\""));
  ASSERT_EQ(bars.size(), 3u);
  for (const auto& b : bars) EXPECT_EQ(std::stod(b), 1.0);  // a fifth of 6 m, down to 1, 2 or 5 x 10^k
  EXPECT_NE(html.find("maximum flow depth [m]"), std::string::npos);
  // The manifests, collapsed, with their hashes.
  for (const auto& r : fixture().store->list_runs("report-test"))
    EXPECT_NE(html.find("<code>" + r.manifest_hash + "</code>"), std::string::npos);
  EXPECT_EQ(all(html, std::regex("<details class=\"manifest\">")).size(), 3u);
}

TEST(Report, SaysWhenNoLadderIsStoredAndReadsAStoredOne) {
  EXPECT_NE(report_html().find("No ladder run for this scene"), std::string::npos);
  // A ladder of C0 as `runout tradeoff` stores one: Q_m 8 % off the finest at dp 0.1, 2 % at 0.05.
  Fixture& f = fixture();
  const double qm[] = {1.08, 1.02, 1.0};
  const char* dps[] = {"dp=0.1", "dp=0.05", "dp=0.025"};
  for (int k = 0; k < 3; ++k) {
    RunStore::RunRecord rec;
    rec.manifest_hash = std::string("ladder-") + dps[k];
    rec.sweep = "tradeoff:report-test/C0";
    rec.variant = dps[k];
    rec.scene = "flume/C0";
    rec.fidelity = "custom";
    rec.status = "completed";
    rec.metrics_json = json{{"monitors", {{{"type", "section"}, {"name", "Outlet"}, {"peak_discharge_m3_s", qm[k]}}}}}.dump();
    f.store->put_run(rec);
  }
  const std::string html = report_html();
  EXPECT_EQ(html.find("No ladder run for this scene"), std::string::npos);
  EXPECT_NE(html.find("tradeoff:report-test/C0"), std::string::npos);
  const std::string row = between(between(html, "<table class=\"conv\">", "</table>"), "<th title=\"" + kQm + "\">", "</tr>");
  ASSERT_FALSE(row.empty());
  // Deviation at the report's dp (0.1), coarsest dp within 5 % and within 10 %.
  EXPECT_NE(row.find("+8.0 %"), std::string::npos) << row;
  EXPECT_NE(row.find("<td>dp 0.05 m</td><td>dp 0.1 m</td>"), std::string::npos) << row;
}

TEST(Report, EscapesTextAndRefusesABaselineOrSweepItDoesNotHave) {
  Fixture& f = fixture();
  const auto runs = f.store->list_runs("report-test");
  StudyReportInput in{"<script>alert(1)</script> & co", {}, runs[0].id};
  for (const auto& r : runs) in.runs.push_back({r.id, r.variant == "C2" ? "C2 \"<i>\"" : r.variant, {}, {}});
  const std::string html = study_report_html(*f.store, in);
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_EQ(html.find("<i>"), std::string::npos);
  EXPECT_NE(html.find("&lt;script&gt;alert(1)&lt;/script&gt; &amp; co"), std::string::npos);
  EXPECT_NE(html.find("C2 &quot;&lt;i&gt;&quot;"), std::string::npos);
  EXPECT_NE(html.find("No map"), std::string::npos);  // no output folder given: said, not a broken image
  EXPECT_EQ(html_escape("a<b>&'\""), "a&lt;b&gt;&amp;&#39;&quot;");

  // Another baseline: C4 is marked so, and C0 gets its differences.
  const std::string c4 = report_html("C4");
  EXPECT_NE(c4.find("<a href=\"#layout-C4\">C4</a> <small>baseline</small>"), std::string::npos);
  EXPECT_NE(between(between(c4, "<table id=\"ranking\"", "</table>"), "#layout-C0", "</tr>").find(" %</small>"),
            std::string::npos);
  try {
    write_study_report(*f.store, "report-test", "C9", f.dir / "runs", f.dir / "x.html");
    ADD_FAILURE() << "C9 is not a layout";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--baseline: 'C9' is not a completed variant of sweep 'report-test' "
                                         "(accepted: C0, C2, C4)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(write_study_report(*f.store, "nope", "", f.dir / "runs", f.dir / "x.html"), std::invalid_argument);
  EXPECT_FALSE(fs::exists(f.dir / "x.html"));
  in.baseline_id = 99999;
  EXPECT_THROW(study_report_html(*f.store, in), std::invalid_argument);
}

// The intensity classes of every layout and the sweep's difference rasters of every layout but the baseline
// are maps of the report too (they were written but not shown), each with its legend.
TEST(Report, ShowsTheIntensityAndDifferenceRastersAsMaps) {
  const std::string html = report_html();
  for (const std::string layout : {"C0", "C2", "C4"}) {
    SCOPED_TRACE(layout);
    const std::string section = between(html, "<section class=\"layout\" id=\"layout-" + layout + "\">", "</section>");
    ASSERT_FALSE(section.empty());
    const std::string intensity = between(section, "<figure class=\"map hazard\" data-raster=\"intensity\">", "</figure>");
    EXPECT_NE(intensity.find("<img class=\"over\" alt=\"intensity classes of " + layout + "\" src=\"data:image/png;base64,iVBORw0KGgo"),
              std::string::npos);
    for (const char* label : {"low", "medium", "high"}) EXPECT_NE(intensity.find(std::string(">") + label + "</text>"), std::string::npos);
    const bool baseline = layout == "C0";
    for (const std::string diff : {"diff_max_depth", "diff_max_hv"}) {
      const std::string fig = between(section, "<figure class=\"map hazard\" data-raster=\"" + diff + "\">", "</figure>");
      EXPECT_EQ(fig.empty(), baseline) << diff;
      if (!baseline) EXPECT_NE(fig.find("this layout minus the sweep's baseline"), std::string::npos) << diff;
    }
  }
}

// Ranking ties, the loads' sign and the words of the table, and a print stylesheet, on a store of made-up runs:
// C2's and C3's Q_m differ in their last bits only (they print 0.02215 both), so they tie and go by name,
// sharing rank 1; C2's dam load turns negative late, which the chart marks with a zero line and the text
// explains.
TEST(Report, TiesGoByNameAndTheLoadsSignAndTheWordsAreExplained) {
  const fs::path dir = fs::temp_directory_path() / "runout-report-ties";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    RunStore store(dir / "runout.db");
    StudyReportInput in{"ties", {}, 0};
    const std::vector<std::pair<std::string, double>> qm = {{"C0", 0.05}, {"C1", 0.03}, {"C2", 0.022150000000000003}, {"C3", 0.02215}};
    for (const auto& [variant, q] : qm) {
      RunStore::RunRecord r;
      r.manifest_hash = "ties-" + variant;
      r.sweep = "ties";
      r.variant = variant;
      r.scene = "flume/" + variant;
      r.status = "completed";
      json monitors = json::array({{{"type", "section"}, {"name", "Outlet"}, {"peak_discharge_m3_s", q}}});
      if (variant == "C2") {
        monitors.push_back({{"type", "structure_load"}, {"name", "CD_P1"}, {"peak_force_n", 30.0}});
        r.series_csv["structure_load_CD_P1"] = "t,force_n\n0,0\n0.5,30\n1,12\n1.5,-25\n";
      }
      r.metrics_json = json{{"monitors", monitors}}.dump();
      const int64_t id = store.put_run(r);
      if (variant == "C0") in.baseline_id = id;
      in.runs.push_back({id, variant, {}, {}});
    }
    const std::string html = study_report_html(store, in);
    const std::string body = between(between(html, "<table id=\"ranking\"", "</table>"), "<tbody>", "</tbody>");
    const auto ranks = all(body, std::regex("<tr[^>]*><td>([0-9]+)</td><th scope=\"row\"><a href=\"#layout-([^\"]+)\""), 0);
    std::vector<std::string> order;
    for (const auto& row : ranks) {
      std::smatch m;
      std::regex_search(row, m, std::regex("<td>([0-9]+)</td>.*#layout-([^\"]+)"));
      order.push_back(m[1].str() + " " + m[2].str());
    }
    EXPECT_EQ(order, (std::vector<std::string>{"1 C2", "1 C3", "3 C1", "4 C0"}));
    EXPECT_NE(html.find("tie: they share a rank and go by name"), std::string::npos);
    // The loads: the sign convention said, the zero line drawn where the load turns negative.
    const std::string loads = between(html, "<section id=\"loads\">", "</section>");
    EXPECT_NE(loads.find("<b>positive</b>, the flow pushes the structure downstream"), std::string::npos) << loads.substr(0, 600);
    EXPECT_NE(loads.find("<b>negative</b>, the net push points upstream"), std::string::npos);
    EXPECT_NE(between(loads, "data-monitor=\"CD_P1\"", "</figure>").find("class=\"zero\""), std::string::npos);
    // "retained" and "upstream" in words beside the table.
    EXPECT_NE(html.find("<b>retained</b>: the flow volume the structure holds at the end"), std::string::npos);
    EXPECT_NE(html.find("<b>upstream</b> (check dams): everything upstream of the dam's axis"), std::string::npos);
    // A print stylesheet: no navigation, tables not cut off in a scroll box, figures not split over pages.
    const std::string print = between(html, "@media print{", "}}");
    EXPECT_NE(print.find("nav{display:none}"), std::string::npos) << print;
    EXPECT_NE(print.find(".scroll{overflow:visible}"), std::string::npos) << print;
    EXPECT_NE(print.find("break-inside:avoid"), std::string::npos) << print;
  }
  fs::remove_all(dir);
}
