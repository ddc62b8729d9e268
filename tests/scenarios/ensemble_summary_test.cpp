// What an ensemble says of each layout (ensemble_summary.hpp): exceedance maps against the probabilities a
// synthetic ensemble has by construction, quantiles by their definition, and first places counted with ties
// shared on a constructed store.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/report.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/terrain/raster.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("runout-ensemble-summary-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  TempDir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

RunStore::RunRecord record(const std::string& variant, const json& metrics) {
  RunStore::RunRecord r;
  r.manifest_hash = "hash-" + variant;
  r.sweep = "s";
  r.variant = variant;
  r.scene = "synthetic";
  r.fidelity = "screening";
  r.status = "completed";
  r.metrics_json = metrics.dump();
  r.manifest_json = "{}";
  return r;
}

json outlet_metrics(double q, double village_arrival) {
  return {{"monitors", json::array({{{"type", "section"}, {"name", "Outlet"}, {"peak_discharge_m3_s", q}}})},
          {"terrain", {{"protected_zones", json::array({{{"name", "Village"}, {"arrival_time_s", village_arrival}}})}}}};
}

}  // namespace

TEST(EnsembleSummary, MemberNamesAreLayoutDashEAndAtLeastThreeDigits) {
  const auto m = split_member_name("G3-e017");
  ASSERT_TRUE(m);
  EXPECT_EQ(m->layout, "G3");
  EXPECT_EQ(m->member, 17);
  EXPECT_EQ(split_member_name("C-e-e1024")->layout, "C-e");
  EXPECT_FALSE(split_member_name("G3"));
  EXPECT_FALSE(split_member_name("G3-e17"));
}

// Hyndman and Fan's type 7, as numpy.quantile computes it: for {1, 2, 3, 4}, p10 = 1.3, p50 = 2.5, p90 = 3.7.
TEST(EnsembleSummary, QuantilesInterpolateBetweenOrderStatistics) {
  EXPECT_NEAR(quantile({4, 1, 3, 2}, 0.1), 1.3, 1e-12);
  EXPECT_NEAR(quantile({4, 1, 3, 2}, 0.5), 2.5, 1e-12);
  EXPECT_NEAR(quantile({4, 1, 3, 2}, 0.9), 3.7, 1e-12);
  EXPECT_EQ(quantile({7}, 0.9), 7);
  EXPECT_THROW(quantile({}, 0.5), std::invalid_argument);
  EXPECT_THROW(quantile({1}, 1.5), std::invalid_argument);
}

// Two members on one lattice, one window shifted by two cells: the union holds both, the share counts a cell
// outside a member as not reaching, and a cell no member reaches is nodata.
TEST(EnsembleSummary, ExceedanceGridIsTheShareOfMembersOnTheUnion) {
  terrain::Grid a(4, 1, 0.0, 1.0, 1.0, 1.0, {}, 1.0f), b(4, 1, 2.0, 1.0, 1.0, 1.0, {}, 0.5f);
  a.at(0, 0) = terrain::Grid::nodata;
  const terrain::Grid p = terrain::exceedance_grid({&a, &b}, 0.5);
  ASSERT_EQ(p.nx, 6);
  EXPECT_TRUE(std::isnan(p.at(0, 0)));
  EXPECT_FLOAT_EQ(p.at(1, 0), 0.5f);
  EXPECT_FLOAT_EQ(p.at(2, 0), 1.0f);
  EXPECT_FLOAT_EQ(p.at(5, 0), 0.5f);
  EXPECT_TRUE(std::isnan(terrain::exceedance_grid({&a, &b}, 2.0).at(2, 0)));
  const terrain::Grid off(2, 1, 0.5, 1.0, 1.0, 1.0);
  EXPECT_THROW(terrain::exceedance_grid({&a, &off}, 0.5), std::invalid_argument);
}

// Member k's depth is h(x) = u_k x / L along a strip of length L, with u_k the k-th point of a 64-point Latin
// hypercube: u is uniform on (0, 1), so P(h >= t) = 1 - t L / x where x >= t L, and 0 before. A Latin
// hypercube has exactly one u in each stratum [k/n, (k+1)/n), so the share reaching t differs from that by less
// than 1/n: the tolerance.
TEST(EnsembleSummary, ExceedanceMapsMatchTheAnalyticProbability) {
  TempDir dir;
  const size_t n = 64;
  const int nx = 50;
  const double L = 50.0;
  const auto u = latin_hypercube(n, 1, 7);
  Sweep sweep;
  sweep.name = "strip";
  sweep.base_json = R"({"output": {"intensity": {"medium_depth": 0.3}}})";
  sweep.ensemble = Ensemble{};
  const std::string crs = terrain::crs_wkt_from("EPSG:32632");
  for (size_t k = 0; k < n; ++k) {
    SweepVariant v;
    v.layout = "A";
    v.member = static_cast<int>(k);
    v.name = "A-e" + std::string(k < 10 ? "00" : "0") + std::to_string(k);
    sweep.variants.push_back(v);
    terrain::Grid h(nx, 1, 500000.0, 5000000.0, 1.0, 1.0, crs, 0.0f);
    for (int i = 0; i < nx; ++i) h.at(i, 0) = static_cast<float>(u[k][0] * (h.cx(i) - 500000.0) / L);
    fs::create_directories(dir.path / v.name / "rasters");
    terrain::write_geotiff((dir.path / v.name / "rasters" / "max_depth.tif").string(), h);
  }
  ASSERT_EQ(write_exceedance_maps(dir.path, sweep), std::vector<std::string>{"A"});
  const fs::path f = dir.path / "A" / "exceedance" / "p_max_depth_medium.tif";
  ASSERT_TRUE(fs::is_regular_file(f));
  EXPECT_TRUE(fs::is_regular_file(dir.path / "A" / "exceedance" / "p_max_depth_medium.qml"));
  EXPECT_FALSE(fs::exists(dir.path / "A" / "exceedance" / "p_max_hv_medium.tif"));  // no member has the raster
  const terrain::Grid p = terrain::load_dem(f.string());
  const double t = 0.3;
  int compared = 0;
  for (int i = 0; i < nx; ++i) {
    const double x = p.cx(i) - 500000.0;
    const double exact = x >= t * L ? 1.0 - t * L / x : 0.0;
    const double got = std::isnan(p.at(i, 0)) ? 0.0 : p.at(i, 0);
    EXPECT_LT(std::abs(got - exact), 1.0 / n) << "x = " << x;
    ++compared;
  }
  EXPECT_EQ(compared, nx);
}

// Three layouts, four members; member 3 lacks C (incomplete, left out). First places: member 0 A, member 1 B,
// member 2 A and B tied as printed (1 and 1.00001 at 4 significant digits): A 1.5/3, B 1.5/3, C 0.
TEST(EnsembleSummary, QuantilesAndFirstPlacesOverCompleteMembers) {
  TempDir dir;
  RunStore store(dir.path / "runout.db");
  const double q[4][3] = {{1, 2, 3}, {2, 1, 3}, {1, 1.00001, 3}, {0.1, 0.1, -1}};
  const char* layouts[3] = {"A", "B", "C"};
  for (int m = 0; m < 4; ++m)
    for (int l = 0; l < 3; ++l) {
      if (q[m][l] < 0) continue;
      const double arrival = (m == 0 && l == 0) ? -1.0 : 10.0 + m;  // A never reaches the Village in member 0
      store.put_run(record(std::string(layouts[l]) + "-e00" + std::to_string(m), outlet_metrics(q[m][l], arrival)));
    }
  store.put_run(record("plain", outlet_metrics(0.0, 1.0)));  // not a member: ignored
  const auto s = summarise_ensemble(store, "s");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->layouts, (std::vector<std::string>{"A", "B", "C"}));
  EXPECT_EQ(s->members, 3u);
  EXPECT_EQ(s->incomplete, 1u);
  EXPECT_EQ(s->ranked_members, 3u);
  EXPECT_EQ(s->ranking_metric, "monitors.section.Outlet.peak_discharge_m3_s");
  EXPECT_NEAR(s->first_share.at("A"), 0.5, 1e-12);
  EXPECT_NEAR(s->first_share.at("B"), 0.5, 1e-12);
  EXPECT_EQ(s->first_share.at("C"), 0.0);
  const MetricQuantiles& qa = s->quantiles.at("A").at(s->ranking_metric);  // {1, 2, 1}
  EXPECT_EQ(qa.count, 3u);
  EXPECT_NEAR(qa.p10, 1.0, 1e-12);
  EXPECT_NEAR(qa.p50, 1.0, 1e-12);
  EXPECT_NEAR(qa.p90, 1.8, 1e-12);
  const MetricQuantiles& va = s->quantiles.at("A").at("terrain.protected_zones.Village.arrival_time_s");
  EXPECT_EQ(va.never, 1u);
  EXPECT_EQ(va.count, 2u);
  const json j = json::parse(ensemble_summary_json(*s));
  EXPECT_EQ(j["layouts_detail"]["A"]["metrics"][s->ranking_metric]["p90"].get<double>(), qa.p90);
  EXPECT_FALSE(summarise_ensemble(store, "no-such-sweep"));
}

// The report of an ensemble sweep opens with the ensemble (first places, quantiles, exceedance maps) and shows
// one member's runs, labelled by layout; --member names another, and one with no run is refused.
TEST(EnsembleSummary, TheReportShowsTheEnsembleAndOneMembersLayouts) {
  TempDir dir;
  RunStore store(dir.path / "runout.db");
  const double q[2][2] = {{1, 2}, {3, 2}};
  for (int m = 0; m < 2; ++m)
    for (int l = 0; l < 2; ++l) {
      auto r = record(std::string(l ? "B" : "A") + "-e00" + std::to_string(m), outlet_metrics(q[m][l], 5.0));
      store.put_run(r);
    }
  terrain::Grid p(3, 2, 500000.0, 5000000.0, 1.0, 1.0, terrain::crs_wkt_from("EPSG:32632"), 0.5f);
  fs::create_directories(dir.path / "runs" / "s" / "A" / "exceedance");
  terrain::write_geotiff((dir.path / "runs" / "s" / "A" / "exceedance" / "p_intensity_high.tif").string(), p,
                         {"P(intensity >= 3 class)", "1", {}});
  const StudyReportInput in = sweep_report_input(store, "s", "", dir.path / "runs");
  ASSERT_TRUE(in.ensemble);
  EXPECT_EQ(in.member, 0);
  ASSERT_EQ(in.runs.size(), 2u);
  EXPECT_EQ(in.runs[0].label, "A");
  EXPECT_EQ(in.runs[0].out_dir, dir.path / "runs" / "s" / "A-e000");
  const std::string html = study_report_html(store, in);
  EXPECT_NE(html.find("Ensemble: 2 members"), std::string::npos);
  EXPECT_NE(html.find("<th>A</th><td>50 %</td>"), std::string::npos);
  EXPECT_NE(html.find("data-raster=\"p_intensity_high\""), std::string::npos);
  EXPECT_EQ(sweep_report_input(store, "s", "B", dir.path / "runs", 1).runs[1].out_dir,
            dir.path / "runs" / "s" / "B-e001");
  EXPECT_THROW(sweep_report_input(store, "s", "", dir.path / "runs", 5), std::invalid_argument);
}
