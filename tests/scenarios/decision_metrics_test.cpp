// The decision metrics (decision_metrics.hpp): which flattened names they are, the outlet, and their order.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "runout/scenarios/decision_metrics.hpp"

namespace runout {
namespace {

// The names a flume layout stores (a sample of them, in the store's sorted order).
const std::vector<std::string> kFlume = {
    "monitors.section.Chute.peak_discharge_m3_s",
    "monitors.section.Chute.volume_passed_m3",
    "monitors.section.Outlet.peak_discharge_m3_s",
    "monitors.section.Outlet.volume_passed_m3",
    "monitors.section.Outlet.arrival_time_s",
    "monitors.structure_load.CD_P2.peak_force_n",
    "monitors.structure_load.CD_P2.peak_force_unfiltered_n",
    "monitors.structure_load.CD_P2.peak_mean_pressure_pa",
    "monitors.structure_load.CD_P1.peak_mean_pressure_pa",
    "monitors.structure_load.CD_P1.peak_force_n",
    "particles.fluid",
    "settings.dp_m",
    "terrain.inundation.inundated_area_m2",
    "terrain.inundation.runout_m",
    "terrain.inundation.max_depth_m",
    "terrain.protected_zones.Village.arrival_time_s",
    "terrain.protected_zones.Village.inundated_area_m2",
    "terrain.structures.check_dam.CD_P2.retained_volume_m3",
    "terrain.structures.check_dam.CD_P2.upstream_volume_m3",
    "terrain.structures.check_dam.CD_P2.crest_elevation_m",
};

TEST(DecisionMetrics, TheSectionNamedOutletIsTheOutletWhateverItsPlace) {
  EXPECT_EQ(DecisionMetrics(kFlume).outlet(), "Outlet");
  // Named like the outlet in any case, a section wins over one later in natural order.
  EXPECT_EQ(DecisionMetrics({"monitors.section.lower_outlet.peak_discharge_m3_s",
                             "monitors.section.Z.peak_discharge_m3_s"})
                .outlet(),
            "lower_outlet");
}

TEST(DecisionMetrics, LayoutsAreRankedByTheOutletsPeakDischarge) {
  EXPECT_EQ(DecisionMetrics(kFlume).ranking_metric(), "monitors.section.Outlet.peak_discharge_m3_s");
  EXPECT_EQ(DecisionMetrics({"terrain.inundation.runout_m"}).ranking_metric(), "");  // no section, no ranking
}

TEST(DecisionMetrics, WithoutAnOutletNameTheLastSectionInNaturalOrderIsTheOutlet) {
  const DecisionMetrics dm({"monitors.section.S2.peak_discharge_m3_s", "monitors.section.S10.peak_discharge_m3_s",
                            "monitors.section.S3.peak_discharge_m3_s"});
  EXPECT_EQ(dm.outlet(), "S10");
  EXPECT_TRUE(dm.is_decision("monitors.section.S10.peak_discharge_m3_s"));
  EXPECT_FALSE(dm.is_decision("monitors.section.S3.peak_discharge_m3_s"));
  EXPECT_EQ(DecisionMetrics({"particles.fluid"}).outlet(), "");
}

TEST(DecisionMetrics, OnlyTheDecisionFieldsAreDecisionMetrics) {
  const DecisionMetrics dm(kFlume);
  EXPECT_TRUE(dm.is_decision("monitors.structure_load.CD_P2.peak_force_n"));
  EXPECT_FALSE(dm.is_decision("monitors.structure_load.CD_P2.peak_force_unfiltered_n"));  // the filtered one counts
  EXPECT_FALSE(dm.is_decision("monitors.section.Chute.peak_discharge_m3_s"));             // not the outlet
  EXPECT_FALSE(dm.is_decision("monitors.section.Outlet.arrival_time_s"));
  EXPECT_FALSE(dm.is_decision("terrain.structures.check_dam.CD_P2.crest_elevation_m"));
  EXPECT_FALSE(dm.is_decision("settings.dp_m"));
  ASSERT_TRUE(dm.rank("terrain.structures.check_dam.CD_P2.retained_volume_m3"));
  EXPECT_EQ(dm.rank("terrain.structures.check_dam.CD_P2.retained_volume_m3")->subject, "CD_P2");
  EXPECT_EQ(dm.rank("terrain.structures.check_dam.CD_P2.retained_volume_m3")->group, 4);
}

TEST(DecisionMetrics, OrderIsOutletThenLoadsRetentionAreaZonesRunoutThenTheRest) {
  const DecisionMetrics dm(kFlume);
  const std::vector<std::string> expected = {
      "monitors.section.Outlet.peak_discharge_m3_s",
      "monitors.section.Outlet.volume_passed_m3",
      "monitors.structure_load.CD_P1.peak_force_n",
      "monitors.structure_load.CD_P1.peak_mean_pressure_pa",
      "monitors.structure_load.CD_P2.peak_force_n",
      "monitors.structure_load.CD_P2.peak_mean_pressure_pa",
      "terrain.structures.check_dam.CD_P2.retained_volume_m3",
      "terrain.structures.check_dam.CD_P2.upstream_volume_m3",
      "terrain.inundation.inundated_area_m2",
      "terrain.protected_zones.Village.inundated_area_m2",
      "terrain.protected_zones.Village.arrival_time_s",
      "terrain.inundation.runout_m",
  };
  EXPECT_EQ(dm.order(kFlume, false), expected);
  const auto all = dm.order(kFlume, true);
  ASSERT_EQ(all.size(), kFlume.size());
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), all.begin()));
  EXPECT_EQ(all[expected.size()], "monitors.section.Chute.peak_discharge_m3_s");  // the rest keep their order
  EXPECT_EQ(all.back(), "terrain.structures.check_dam.CD_P2.crest_elevation_m");
}

TEST(DecisionMetrics, NaturalOrderComparesDigitRunsAsNumbers) {
  EXPECT_TRUE(natural_less("S2", "S10"));
  EXPECT_FALSE(natural_less("S10", "S2"));
  EXPECT_TRUE(natural_less("Dam1", "Dam1a"));
  EXPECT_FALSE(natural_less("G7", "G7"));
  EXPECT_TRUE(natural_less("CD_P1", "FD_P1"));
}

// Every decision metric has a label for people and a direction (the web page colours differences by it and the
// report its ranking table): a later arrival and more held back are better, less of the rest.
TEST(DecisionMetrics, EachDecisionMetricHasALabelAndADirection) {
  const DecisionMetrics dm(kFlume);
  EXPECT_EQ(dm.label("monitors.section.Outlet.peak_discharge_m3_s"), "Outlet Q_m [m³/s]");
  EXPECT_EQ(dm.label("terrain.structures.check_dam.CD_P2.retained_volume_m3"), "CD_P2 retained [m³]");
  EXPECT_EQ(dm.label("terrain.protected_zones.Village.arrival_time_s"), "Village arrival [s]");
  EXPECT_EQ(dm.label("steps"), "steps");  // not a decision metric: its own name
  for (const auto& name : dm.order(kFlume, false)) {
    EXPECT_NE(dm.label(name), name) << name;
    const bool higher = name.find("arrival_time_s") != std::string::npos ||
                        (name.find("_volume_m3") != std::string::npos && name.find("volume_passed") == std::string::npos);
    EXPECT_EQ(DecisionMetrics::higher_is_better(name), higher) << name;
  }
}

}  // namespace
}  // namespace runout
